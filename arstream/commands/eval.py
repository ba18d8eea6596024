"""``arstream eval``: score predicted cameras against ground truth."""

from __future__ import annotations

import json

from arstream.commands.synth import _size

ORDER = 60


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "eval",
        help="score cameras.jsonl against a synthetic clip's truth.jsonl",
        description=(
            "Score predicted cameras against ground truth: coverage, reprojection error of the pitch "
            "markings (median, mean, p95), acc@5/10/20 px, focal error, jitter, and estimates given "
            "on frames without a pitch."
        ),
    )
    p.add_argument("--truth", required=True, help="truth.jsonl (header.json beside it gives the frame size)")
    p.add_argument("--pred", required=True, help="cameras.jsonl to score")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="frame size if there is no header.json")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)


def run(args) -> int:
    from arstream.evaluate import format_table, score_files

    s = score_files(args.truth, args.pred, args.size)
    print(json.dumps(s.to_dict(), indent=2) if args.json else format_table(s))
    return 0
