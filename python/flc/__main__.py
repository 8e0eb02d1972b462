"""``python -m flc figures --out DIR [--speeds 30,50,70,90] [--preset paper|realistic]``."""
from __future__ import annotations

import argparse
import sys
from typing import Optional, Sequence


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m flc", description="flc command line")
    sub = parser.add_subparsers(dest="command", required=True)
    fig = sub.add_parser("figures", help="write the paper's figures (Fig. 2, Fig. 4, Lyapunov) as PNG")
    fig.add_argument("--out", required=True, help="output directory")
    fig.add_argument("--speeds", default="30,50,70,90", help="max speeds of Fig. 4, km/h, comma separated")
    fig.add_argument("--preset", choices=["paper", "realistic"], default="paper", help="vehicle preset of Fig. 4")
    args = parser.parse_args(argv)
    try:
        speeds = [float(s) for s in args.speeds.split(",") if s.strip()]
    except ValueError:
        parser.error(f"--speeds: expected numbers, got {args.speeds!r}")
    if not speeds:
        parser.error("--speeds: give at least one speed")
    from .figures import make_all

    for p in make_all(args.out, speeds, args.preset):
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
