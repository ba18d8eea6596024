"""``arstream calib``: the calibration tools (sub-commands from ``calib_*`` modules).

Every tool prints one JSON object on stdout (``--pretty`` indents it); its
worked example, with the input formats, is in docs/calib.md.
"""

from __future__ import annotations

import argparse
import json
import sys

from arstream.commands import discover

ORDER = 80


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calib",
        help="calibrate cameras from spheres, 1-D objects, laser planes; fundamental matrices",
        description=(
            "Calibration tools for fixed multi-camera rigs. Each prints one JSON object on stdout "
            "(--pretty indents it). Worked examples and the input file formats: docs/calib.md."
        ),
    )
    sub = p.add_subparsers(dest="calib_command", metavar="TOOL")
    for mod in discover("calib_"):
        mod.register(sub)

    def _no_tool(args: argparse.Namespace) -> int:
        p.print_help()
        return 2

    p.set_defaults(func=_no_tool)


def add_output_arguments(p) -> None:
    """The output option every calibration tool shares: ``--pretty``."""
    p.add_argument("--pretty", action="store_true", help="indent the JSON")


def print_report(report: dict, args: argparse.Namespace) -> None:
    """Print a tool's result: one JSON object on stdout, indented with ``--pretty``."""
    json.dump(report, sys.stdout, indent=2 if args.pretty else None)
    sys.stdout.write("\n")
