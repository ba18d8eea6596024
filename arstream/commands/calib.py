"""``arstream calib``: the calibration tools (sub-commands from ``calib_*`` modules)."""

from __future__ import annotations

import argparse

from arstream.commands import discover

ORDER = 80


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calib",
        help="calibrate cameras from spheres, 1-D objects, laser planes; fundamental matrices",
        description="Calibration tools for fixed multi-camera rigs. Each prints JSON.",
    )
    sub = p.add_subparsers(dest="calib_command", metavar="TOOL")
    for mod in discover("calib_"):
        mod.register(sub)

    def _no_tool(args: argparse.Namespace) -> int:
        p.print_help()
        return 2

    p.set_defaults(func=_no_tool)
