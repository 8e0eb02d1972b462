"""``python -m flc figures --out DIR [--speeds 30,50,70,90] [--preset paper|realistic] [--no-envelope] [--platoon-frequencies HZ,...]``,
``python -m flc reproduction --out DIR``,
``python -m flc sumo-tables --out DIR`` (every SUMO result the documents state, ``DIR/sumo-tables.json``; :mod:`flc.sumo`),
``python -m flc sweep FILE [--out X.csv|X.parquet] [--dask SCHEDULER_ADDRESS] [--chunk-size N] [--series] [--restart]``,
``python -m flc falsify SPEC.toml [--out DIR] [--budget N] [--seed N]`` (a CMA-ES search for the least robust run, :mod:`flc._falsify`),
``python -m flc docs [--check] [--root DIR] [FILE ...]`` / ``python -m flc docs show NAME [ARG ...]`` / ``python -m flc docs list``
(the documents' generated blocks, :mod:`flc.docs`; exit 1 when ``--check`` finds a block that differs; they need the
source tree: the one this package runs from, a checkout around the working directory, or ``--root DIR``; exit 2
when there is none).

Exit status 0 on success, 2 on bad arguments (argparse), a bad sweep file or no source tree for a command
that needs one, 1 if an optional
dependency (matplotlib, pyarrow, distributed, SUMO) is missing.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Optional, Sequence

from ._paths import SOURCE_TREE_ENV, SourceTreeError, require_source_tree


def _speeds(text: str) -> list[float]:
    try:
        speeds = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers (km/h), got {text!r}") from None
    from ._flc import paper_speed_range_kmh

    lo, hi = paper_speed_range_kmh()  # the one limit of every entry point (flc_sim::paper::SPEED_RANGE_KMH)
    if not speeds or not all(lo <= v <= hi for v in speeds):
        raise argparse.ArgumentTypeError(f"expected one or more speeds in [{lo:g}, {hi:g}] km/h, got {text!r}")
    return speeds


def _controllers(text: str) -> list[str]:
    from ._scenario import CONTROLLERS

    names = [c.strip() for c in text.split(",") if c.strip()]
    bad = [c for c in names if c not in CONTROLLERS]
    if not names or bad:
        raise argparse.ArgumentTypeError(f"expected controllers from {', '.join(CONTROLLERS)}, got {text!r}")
    return names


def _freqs(text: str) -> list[float]:
    try:
        freqs = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers (Hz), got {text!r}") from None
    if not freqs or not all(0.001 <= f <= 5.0 for f in freqs):
        raise argparse.ArgumentTypeError(f"expected one or more frequencies in [0.001, 5] Hz, got {text!r}")
    return freqs


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["docs"] and argv[1:2] not in (["-h"], ["--help"]):
        # Its own small grammar (`--check`, `show NAME ARG...`): flc.docs parses it. `--root DIR`
        # names the source tree whose documents it reads (before flc.docs looks for one).
        rest = argv[1:]
        if "--root" in rest:
            i = rest.index("--root")
            if i + 1 >= len(rest):
                print("error: `--root` needs the source tree's folder", file=sys.stderr)
                return 2
            os.environ[SOURCE_TREE_ENV] = rest[i + 1]
            rest = rest[:i] + rest[i + 2 :]
        from . import docs

        return docs.main(rest)
    if argv[:1] == ["falsify"]:
        from ._falsify import main as falsify_main

        return falsify_main(argv[1:])
    parser = argparse.ArgumentParser(prog="python -m flc", description="flc command line")
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser(
        "reproduction",
        help="the paper's outcome pattern over the constants it leaves open: sweeps/paper-reproduction-*.csv and two figures (docs/paper-reproduction.md)",
    )
    rep.add_argument("--out", required=True, help="figure directory (created if needed)")
    rep.add_argument("--data", default=None, help="CSV directory (default: the source tree's sweeps/; needed outside a checkout)")
    rep.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores); results do not depend on it")
    st = sub.add_parser(
        "sumo-tables",
        help="run the SUMO comparisons the documents state (docs/sumo.md, docs/v2v-and-metrics.md): DIR/sumo-tables.json (needs flc[sumo])",
    )
    st.add_argument("--out", required=True, help="output directory (created if needed); the documents read docs/figures")
    sw = sub.add_parser(
        "sweep",
        help="run a sweep file (TOML) or OpenSCENARIO distribution with the Rust sweep engine, here or on a Dask cluster (docs/distributed.md)",
    )
    sw.add_argument("file", help="the sweep file (.toml) or distribution (.xosc)")
    sw.add_argument("--out", default=None, help="output: X.csv (default: FILE with .csv) or X.parquet (a directory of Parquet parts)")
    sw.add_argument("--dask", metavar="SCHEDULER_ADDRESS", default=None, help="run on the Dask cluster of this scheduler (tcp://host:8786)")
    sw.add_argument("--chunk-size", type=int, default=None, help="runs per task (default: automatic, flc.sweep_file)")
    sw.add_argument("--threads", type=int, default=None, help="local threads without --dask (default: all cores); results do not depend on it")
    sw.add_argument("--series", action="store_true", help="also write every run's series as <out stem>-series/<run_id>.parquet")
    sw.add_argument(
        "--restart",
        action="store_true",
        help="start the output over; without it an output whose rows ran other inputs (changed sweep file, scenario or flc version) is refused",
    )
    sw.add_argument("--quiet", action="store_true", help="no progress bar (drawn on stderr only when it is a terminal)")
    dc = sub.add_parser(
        "docs",
        help="rewrite (or with --check, compare) the generated blocks of README.md and docs/*.md; `docs show NAME [ARG ...]` prints one block (docs/README.md)",
    )
    dc.add_argument("docs_args", nargs=argparse.REMAINDER, help="[--check] [FILE ...] | show NAME [ARG ...] | list")
    fig = sub.add_parser("figures", help="write the paper's figures (Fig. 2, Fig. 4, Lyapunov), the safety-envelope maps and the platoon figures as PNG")
    fig.add_argument("--out", required=True, help="output directory (created if needed)")
    fig.add_argument("--speeds", type=_speeds, default=[30.0, 50.0, 70.0, 90.0], help="max speeds of Fig. 4, km/h, comma separated (default 30,50,70,90)")
    fig.add_argument("--preset", choices=["paper", "realistic"], default="paper", help="vehicle preset of Fig. 4 (default paper)")
    fig.add_argument("--no-envelope", action="store_true", help="skip the safety-envelope maps (2 145 runs, ~75 s on 2 cores)")
    fig.add_argument("--quiet", action="store_true", help="no progress on stderr (shown only when it is a terminal)")
    fig.add_argument(
        "--envelope-preset", choices=["paper", "realistic"], default="realistic", help="vehicle preset of the safety-envelope maps (default realistic)"
    )
    fig.add_argument(
        "--envelope-speeds", type=_speeds, default=None, help="max speeds of the envelope maps, km/h, comma separated (default 30,40,...,150)"
    )
    fig.add_argument(
        "--envelope-controllers",
        type=_controllers,
        default=None,
        help="controllers of the envelope maps, comma separated (default: every controller but pipeline, flc.envelope.CONTROLLERS)",
    )
    fig.add_argument("--threads", type=int, default=None, help="worker threads of the envelope sweeps (default: all cores)")
    fig.add_argument(
        "--platoon-frequencies",
        type=_freqs,
        default=None,
        help="frequencies of the platoon's |Gamma(jw)|, Hz, comma separated (default: the brake demo's 0.05,0.1,0.2,0.3,0.5)",
    )
    args = parser.parse_args(argv)
    if getattr(args, "threads", None) is not None and args.threads < 1:
        parser.error("--threads: expected a positive number")
    if args.command == "sweep":
        return _sweep(parser, args)
    if args.command == "docs":
        from . import docs

        return docs.main(args.docs_args)
    if args.command == "sumo-tables":
        try:
            from . import sumo

            path = sumo.write_tables(args.out, progress=lambda text: print(f"{text} done", file=sys.stderr))
        except ImportError as e:
            print(f"error: {e} (install flc[sumo])", file=sys.stderr)
            return 1
        print(path)
        return 0
    if args.command == "reproduction":
        try:
            from .figures import make_reproduction

            data = args.data if args.data is not None else require_source_tree("`python -m flc reproduction` (it rewrites sweeps/paper-reproduction-*.csv; or give --data DIR)") / "sweeps"
            summary = make_reproduction(args.out, data_dir=data, threads=args.threads)
        except ImportError as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        except SourceTreeError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        print(summary)
        return 0
    try:
        from . import envelope
        from .figures import make_all

        from ._progress import Bar, stderr_is_terminal

        bar = None if args.quiet or not stderr_is_terminal() else Bar(0, "figures")
        paths = make_all(args.out, args.speeds, args.preset, args.platoon_frequencies, progress=bar)
        if bar is not None:
            bar.close()
        if not args.no_envelope:
            runs = None if bar is None else Bar(0, "envelope runs")
            paths += envelope.make_all(
                args.out,
                controllers=args.envelope_controllers or envelope.CONTROLLERS,
                speeds_kmh=args.envelope_speeds or envelope.SPEEDS_KMH,
                preset=args.envelope_preset,
                threads=args.threads,
                progress=None if runs is None else (lambda d, n, stem: runs(d, n, stem)),
            )
            if runs is not None:
                runs.close()
    except ImportError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    except FileNotFoundError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


def _sweep(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    from ._flc import FlcError, ParameterError, ScenarioError
    from ._sweep import sweep_file

    if args.chunk_size is not None and args.chunk_size < 1:
        parser.error("--chunk-size: expected a positive number")
    client = None
    try:
        if args.dask is not None:
            import distributed

            client = distributed.Client(args.dask)
        s = sweep_file(
            args.file,
            executor=client,
            out=args.out,
            chunk_size=args.chunk_size,
            series=args.series,
            threads=args.threads,
            progress=False if args.quiet else None,
            restart=args.restart,
        )
    except ImportError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    except (ScenarioError, ParameterError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except (FlcError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
    print(f"{s.done} runs done ({s.total} in the sweep, {s.skipped} already there), rows in {s.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
