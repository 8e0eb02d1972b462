"""``python -m flc figures --out DIR [--speeds 30,50,70,90] [--preset paper|realistic]``.

Exit status 0 on success, 2 on bad arguments (argparse), 1 if matplotlib is missing.
"""
from __future__ import annotations

import argparse
import sys
from typing import Optional, Sequence


def _speeds(text: str) -> list[float]:
    try:
        speeds = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers (km/h), got {text!r}") from None
    if not speeds or not all(0 < v <= 250 for v in speeds):
        raise argparse.ArgumentTypeError(f"expected one or more speeds in (0, 250] km/h, got {text!r}")
    return speeds


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m flc", description="flc command line")
    sub = parser.add_subparsers(dest="command", required=True)
    fig = sub.add_parser("figures", help="write the paper's figures (Fig. 2, Fig. 4, Lyapunov) as PNG")
    fig.add_argument("--out", required=True, help="output directory (created if needed)")
    fig.add_argument("--speeds", type=_speeds, default=[30.0, 50.0, 70.0, 90.0], help="max speeds of Fig. 4, km/h, comma separated (default 30,50,70,90)")
    fig.add_argument("--preset", choices=["paper", "realistic"], default="paper", help="vehicle preset of Fig. 4 (default paper)")
    args = parser.parse_args(argv)
    try:
        from .figures import make_all

        paths = make_all(args.out, args.speeds, args.preset)
    except ImportError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
