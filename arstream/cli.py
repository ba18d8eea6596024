"""The ``arstream`` command line: a thin layer that parses and calls the library.

Each sub-command lives in ``arstream/commands/<name>.py``. Errors are one line
on stderr and an exit code (2: bad input or usage, 1: processing failure,
130: interrupted); a bug is one line too ("internal error", exit code 1), after the
outputs were finalised. ``--verbose`` (before or after the command) adds the
traceback. A reader that closes stdout early (``arstream ... | head``) ends
the command quietly, as Python's documentation advises for SIGPIPE: the rest
of stdout goes to ``/dev/null`` and the exit code is 1.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import traceback

from arstream import __version__
from arstream.commands import discover
from arstream.errors import ArstreamError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="arstream",
        description=(
            "Augmented reality on broadcast soccer video: find the pitch markings, "
            "solve the camera of every frame, and draw graphics glued to the pitch."
        ),
        epilog="Run 'arstream COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"arstream {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="show tracebacks and debug output")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in discover():
        mod.register(sub)
    _verbose_everywhere(parser)
    return parser


def _verbose_everywhere(parser: argparse.ArgumentParser) -> None:
    """Accept ``-v/--verbose`` after every (sub-)command too, not only before the
    first one. The sub-parsers' flag has no default (SUPPRESS), so it only sets
    ``verbose`` when given and never resets the top-level one."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in dict.fromkeys(action.choices.values()):  # aliases map to the same parser
                if "--verbose" not in child._option_string_actions:
                    child.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="show tracebacks and debug output")
                _verbose_everywhere(child)


def _stdout_closed() -> int:
    """The reader of stdout went away (EPIPE): send the rest of stdout to
    /dev/null, so that the interpreter's final flush does not fail again, and
    return 1 (Python's documentation, "Note on SIGPIPE")."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (a caller's stream)
        return 1
    with open(os.devnull, "w") as devnull:
        os.dup2(devnull.fileno(), fd)
    return 1


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except BrokenPipeError:
        return _stdout_closed()


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit:  # --help, --version, usage errors: flushed here, where EPIPE is caught
        sys.stdout.flush()
        raise
    if not getattr(args, "func", None):
        parser.print_help()
        sys.stdout.flush()
        return 2
    try:
        code = int(args.func(args) or 0)
        sys.stdout.flush()  # an early-closed reader fails here, not in the interpreter's shutdown
        return code
    except BrokenPipeError:
        raise
    except KeyboardInterrupt:
        print("arstream: interrupted", file=sys.stderr)
        return 130
    except (ArstreamError, ValueError, OSError) as exc:
        if args.verbose:
            traceback.print_exc()
        code = getattr(exc, "exit_code", 2 if isinstance(exc, (ValueError, OSError)) else 1)
        print(f"arstream: error: {exc}", file=sys.stderr)
        return code
    except Exception as exc:  # a bug: one line (the outputs were finalised on the way out)
        if args.verbose:
            traceback.print_exc()
        where = "" if args.verbose else " (--verbose shows the traceback)"
        print(f"arstream: internal error: {type(exc).__name__}: {exc}{where}", file=sys.stderr)
        return 1


def entry(argv: list[str] | None = None) -> int:
    """The installed ``arstream`` command: :func:`main`, then a quick exit.

    When :func:`main` returns, every output is finalised. The interpreter's
    shutdown would then run the cyclic garbage collector over everything the
    libraries loaded (numba, scipy, the GL context: several hundred thousand
    objects), which took about 0.5 s of every ``arstream process``. Moving
    them to the collector's permanent generation (``gc.freeze``) skips those
    passes; the rest of the shutdown (atexit hooks, modules, threads) is as
    usual. Library callers of :func:`main` keep their collector untouched.
    """
    code = main(argv)
    gc.freeze()
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(entry())
