#!/usr/bin/env python3
"""ASAM's quality checker over every OpenSCENARIO / OpenDRIVE file the project ships or writes.

Runs the standards body's own checker bundles (PyPI `asam-qc-openscenarioxml` for `.xosc`,
`asam-qc-opendrive` for `.xodr`; pinned in `tools/asam_qc-requirements.txt`) on each file and
fails on any issue, printing one line per issue: file, line, rule UID, message.

    python3 -m venv target/qc-venv && target/qc-venv/bin/pip install -r tools/asam_qc-requirements.txt
    target/qc-venv/bin/python tools/asam_qc.py              # the project's files; exit 1 on any issue
    target/qc-venv/bin/python tools/asam_qc.py --self-test  # files with known faults must be flagged
    target/qc-venv/bin/python tools/asam_qc.py DIR_OR_FILE... --no-fail --json out.json   # any files

What "the project's files" are (`./tests/run_all.sh` checks them all):
* every `.xosc` / `.xodr` under `tests/data/openscenario/` (fixtures, catalogs, roads) and
  `python/flc/data/suites` (the standard suites and their road; `scenarios/suites` links there);
* what the generators write: `tools/fixture_cases.py` and `tools/suite_cases.py` are run into a
  temporary folder and must write exactly the committed files (else the committed ones are stale
  and the check fails, naming the generator to run), so checking the committed files checks what
  the generators write. The Rust side writes no OpenSCENARIO (`scenario convert` writes TOML).

A file that is non-standard on purpose (a fixture of an extension esmini plays and flc accepts
with a warning) is listed in `EXPECTED` below with the rules it must break: those findings are
required (so the fixture keeps testing what it says) and any other finding fails.

Each bundle runs in-process through its own command-line entry point (`qc_openscenario -c CONFIG`,
`qc_opendrive -c CONFIG`, as their READMEs document, with a per-file configuration), in `-j`
worker processes; every result is kept as the standard `.xqar` file in `--xqar` (default
`target/asam-qc/`), which the framework's report modules render (`qc_report_text -r FILE.xqar`).
The framework's `qc_runtime` is not used: it needs a result-pooling module that is not on PyPI.

A checker that skips because an earlier one found an issue (the schema check gates the rest) or
that ends in an error counts as a failure too: "0 issues" means every applicable check ran.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Folders whose `.xosc` / `.xodr` files the project ships.
SHIPPED = ["tests/data/openscenario", "python/flc/data/suites"]
#: Generators and the folder (relative to ROOT) they write; each takes `--out DIR`.
GENERATORS = [("tools/fixture_cases.py", "tests/data/openscenario"), ("tools/suite_cases.py", "python/flc/data/suites")]
#: Files that break ASAM rules on purpose: path relative to ROOT -> rule UIDs that must be found.
EXPECTED: dict[str, set[str]] = {}
#: A checker skipped for one of these reasons did not run because of the file's version or content
#: (e.g. a rule from 1.2 on a 1.0 file, a signal check on a file without a road): not a failure.
BENIGN_SKIPS = ("Version ", "Cannot read xodr", "Cannot find ")


def bundle_for(path: Path) -> tuple[str, str]:
    """(module, bundle name) of the checker bundle for `path`."""
    return ("qc_opendrive", "xodrBundle") if path.suffix.lower() == ".xodr" else ("qc_openscenario", "xoscBundle")


def xml_attr(value: str) -> str:
    return value.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def check_file(path: str, xqar_dir: str) -> dict:
    """Run the bundle on one file (in this worker process) and return its findings."""
    import importlib
    import logging

    p = Path(path).resolve()
    module, bundle = bundle_for(p)
    out = Path(xqar_dir)
    tag = str(p.relative_to(ROOT) if p.is_relative_to(ROOT) else p).replace("/", "__").replace("\\", "__")
    config, xqar = out / f"{tag}.config.xml", out / f"{tag}.xqar"
    config.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<Config>\n'
        f'  <Param name="InputFile" value="{xml_attr(str(p))}"/>\n'
        f'  <CheckerBundle application="{bundle}">\n    <Param name="resultFile" value="{xml_attr(str(xqar))}"/>\n  </CheckerBundle>\n'
        "</Config>\n")
    # The bundles configure logging at INFO on import (basicConfig): configured first, only warnings show.
    logging.basicConfig(format="%(message)s", level=logging.WARNING)
    logging.getLogger("xmlschema").setLevel(logging.WARNING)
    main = importlib.import_module(f"{module}.main")
    logging.getLogger().setLevel(logging.WARNING)
    argv, cwd = sys.argv, os.getcwd()
    try:
        sys.argv = [module, "-c", str(config)]
        main.main()
    finally:
        sys.argv = argv
        os.chdir(cwd)
    from qc_baselib import Result

    result = Result()
    result.load_from_file(str(xqar))
    issues, not_run = [], []
    for b in result.get_checker_bundle_results():
        for c in b.checkers:
            status = getattr(c.status, "value", str(c.status)).lower()
            for i in c.issues:
                rows = [(fl.row, fl.column) for loc in i.locations for fl in loc.file_location if fl.row is not None]
                where = [x.xpath for loc in i.locations for x in loc.xml_location]
                detail = [loc.description for loc in i.locations if loc.description]
                issues.append({"rule": i.rule_uid, "level": getattr(i.level, "name", str(i.level)).lower(), "message": i.description,
                               "line": rows[0][0] if rows else None, "xpath": where[0] if where else None,
                               "detail": "; ".join(detail)})
            if status == "error" or (status == "skipped" and not c.summary.startswith(BENIGN_SKIPS)):
                not_run.append({"checker": c.checker_id, "status": status, "summary": c.summary.strip()})
    return {"file": str(p), "bundle": bundle, "xqar": str(xqar), "issues": issues, "not_run": not_run}


def shipped_files() -> list[Path]:
    files = []
    for d in SHIPPED:
        for ext in ("*.xosc", "*.xodr"):
            files += (ROOT / d).rglob(ext)
    return sorted(set(files))


def stale_generated() -> list[str]:
    """Run each generator into a temporary folder; name every file it writes that differs from
    (or is missing in) the committed tree."""
    problems = []
    for gen, target in GENERATORS:
        with tempfile.TemporaryDirectory(prefix="asam-qc-gen-") as tmp:
            p = subprocess.run([sys.executable, str(ROOT / gen), "--out", tmp], cwd=ROOT, capture_output=True, text=True)
            if p.returncode != 0:
                problems.append(f"{gen} --out {tmp} failed (exit {p.returncode}): {p.stderr.strip()[-500:]}")
                continue
            written = [f for f in Path(tmp).rglob("*") if f.is_file() and f.suffix in (".xosc", ".xodr")]
            if not written:
                problems.append(f"{gen} wrote no .xosc/.xodr file")
            for f in sorted(written):
                committed = ROOT / target / f.relative_to(tmp)
                if not committed.is_file() or committed.read_bytes() != f.read_bytes():
                    problems.append(f"{committed.relative_to(ROOT)}: differs from what {gen} writes (run python3 {gen})")
    return problems


def run(files: list[Path], jobs: int, xqar_dir: Path) -> list[dict]:
    xqar_dir.mkdir(parents=True, exist_ok=True)
    with concurrent.futures.ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = [pool.submit(check_file, str(f), str(xqar_dir)) for f in files]
        return [f.result() for f in futures]


def shown(path: str) -> str:
    p = Path(path)
    return str(p.relative_to(ROOT)) if p.is_relative_to(ROOT) else str(p)


def verdict(results: list[dict], expected: dict[str, set[str]]) -> list[str]:
    """One line per problem: an unexpected issue, a check that did not run, an expected rule not found."""
    lines = []
    for r in results:
        name = shown(r["file"])
        want = expected.get(name, set())
        found = {i["rule"] for i in r["issues"]}
        for i in r["issues"]:
            if i["rule"] in want:
                continue
            where = f":{i['line']}" if i["line"] else ""
            extra = "; ".join(x for x in (i["detail"], i["xpath"]) if x)
            lines.append(f"{name}{where}: {i['rule']}: {i['message']}" + (f" ({extra})" if extra else ""))
        if r["issues"] and r["not_run"]:
            if not want:
                lines.append(f"{name}: {len(r['not_run'])} more checks did not run (an earlier check found an issue)")
        else:
            for c in r["not_run"]:
                lines.append(f"{name}: {c['checker']} {c['status']}: {c['summary']}")
        for rule in sorted(want - found):
            lines.append(f"{name}: expected a finding of {rule} (EXPECTED in tools/asam_qc.py), none found")
    return lines


def rule_summary(results: list[dict]) -> list[str]:
    counts: dict[str, set[str]] = {}
    for r in results:
        for i in r["issues"]:
            counts.setdefault(f"{i['rule']}: {i['message']}", set()).add(r["file"])
    return [f"{len(v):4d} files  {k}" for k, v in sorted(counts.items(), key=lambda kv: -len(kv[1]))]


# ---------------------------------------------------------------------------------------------
# Self-test: the gate can fail. Each case is a small file of this script's own with one known
# fault, and the rule the checker must report for it.

HEADER = '<FileHeader revMajor="1" revMinor="{minor}" date="2026-12-01T00:00:00" author="flc" description="asam_qc self-test"/>'


def _scenario(minor: int, act_trigger: bool, speed: str) -> str:
    trigger = ('<StartTrigger><ConditionGroup><Condition name="C" delay="0" conditionEdge="none"><ByValueCondition>'
               '<SimulationTimeCondition value="0" rule="greaterThan"/></ByValueCondition></Condition></ConditionGroup></StartTrigger>')
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<OpenSCENARIO>
  {HEADER.format(minor=minor)}
  <ParameterDeclarations><ParameterDeclaration name="V" parameterType="double" value="10"/></ParameterDeclarations>
  <CatalogLocations/>
  <RoadNetwork/>
  <Entities>
    <ScenarioObject name="Ego">
      <Vehicle name="car" vehicleCategory="car">
        <BoundingBox><Center x="1.4" y="0" z="0.75"/><Dimensions width="1.8" length="4.5" height="1.5"/></BoundingBox>
        <Performance maxSpeed="70" maxAcceleration="10" maxDeceleration="10"/>
        <Axles><FrontAxle maxSteering="0.5" wheelDiameter="0.6" trackWidth="1.6" positionX="2.8" positionZ="0.3"/>
          <RearAxle maxSteering="0" wheelDiameter="0.6" trackWidth="1.6" positionX="0" positionZ="0.3"/></Axles>
        <Properties/>
      </Vehicle>
    </ScenarioObject>
  </Entities>
  <Storyboard>
    <Init><Actions><Private entityRef="Ego"><PrivateAction><TeleportAction><Position><WorldPosition x="0" y="0"/></Position></TeleportAction></PrivateAction></Private></Actions></Init>
    <Story name="S">
      <Act name="A">
        <ManeuverGroup name="G" maximumExecutionCount="1">
          <Actors selectTriggeringEntities="false"><EntityRef entityRef="Ego"/></Actors>
          <Maneuver name="M">
            <Event name="E" priority="{'override' if minor >= 2 else 'overwrite'}" maximumExecutionCount="1">
              <Action name="Go"><PrivateAction><LongitudinalAction><SpeedAction>
                <SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/>
                <SpeedActionTarget><AbsoluteTargetSpeed value="{speed}"/></SpeedActionTarget>
              </SpeedAction></LongitudinalAction></PrivateAction></Action>
              {trigger}
            </Event>
          </Maneuver>
        </ManeuverGroup>
        {trigger if act_trigger else ''}
      </Act>
    </Story>
    <StopTrigger/>
  </Storyboard>
</OpenSCENARIO>
"""


SELF_TEST = [
    ("clean.xosc", _scenario(2, True, "$V"), None),
    ("clean13.xosc", _scenario(3, False, "${$V * 2}"), None),
    ("act_without_trigger_12.xosc", _scenario(2, False, "$V"), "asam.net:xosc:1.0.0:xml.valid_schema"),
    ("expression_in_10.xosc", _scenario(0, True, "${$V / 3.6}"), "asam.net:xosc:1.0.0:xml.valid_schema"),
    ("extension_function.xosc", _scenario(3, False, "${sin($V)}"), "asam.net:xosc:1.2.0:data_type.allowed_operators"),
    ("no_header.xodr", '<?xml version="1.0" encoding="UTF-8"?>\n<OpenDRIVE>\n</OpenDRIVE>\n',
     "asam.net:xodr:1.0.0:xml.fileheader_is_present"),
]


def self_test(jobs: int, xqar_dir: Path) -> int:
    with tempfile.TemporaryDirectory(prefix="asam-qc-self-") as tmp:
        files = []
        for name, text, _ in SELF_TEST:
            (Path(tmp) / name).write_text(text)
            files.append(Path(tmp) / name)
        results = {Path(r["file"]).name: r for r in run(files, jobs, xqar_dir)}
    bad = []
    for name, _, rule in SELF_TEST:
        r = results[name]
        rules = sorted({i["rule"] for i in r["issues"]})
        if rule is None and (rules or r["not_run"]):
            bad.append(f"{name}: expected no finding, got {rules} {r['not_run']}")
        if rule is not None and rule not in rules:
            bad.append(f"{name}: expected {rule}, got {rules}")
        print(f"self-test {name}: {', '.join(rules) or 'no issue'}")
    for b in bad:
        print(f"error: self-test {b}", file=sys.stderr)
    print("self-test: " + ("failed" if bad else f"the checker flags each of the {len(SELF_TEST) - 2} faulty files and passes the 2 clean ones"))
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("paths", nargs="*", help="files or folders (default: the project's files, and the generators' output checked for staleness)")
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--xqar", default=str(ROOT / "target" / "asam-qc"), help="folder for the checker's .xqar results")
    ap.add_argument("--json", help="write every file's findings to this JSON file")
    ap.add_argument("--no-fail", action="store_true", help="exit 0 whatever is found (for other people's files)")
    ap.add_argument("--summary", action="store_true", help="also print how many files break each rule")
    ap.add_argument("--self-test", action="store_true", help="check files with known faults and clean ones; exit 1 unless each is judged right")
    args = ap.parse_args(argv)
    try:
        import qc_openscenario.main  # noqa: F401
        import qc_opendrive.main  # noqa: F401
    except ImportError as e:
        print(f"error: ASAM's checker is not installed ({e}): pip install -r tools/asam_qc-requirements.txt", file=sys.stderr)
        return 2
    xqar_dir = Path(args.xqar)
    if args.self_test:
        return self_test(args.jobs, xqar_dir / "self-test")
    t0 = time.monotonic()
    problems: list[str] = []
    if args.paths:
        files = []
        for a in args.paths:
            p = Path(a)
            if p.is_dir():
                files += sorted(set(p.rglob("*.xosc")) | set(p.rglob("*.xodr")))
            elif p.is_file():
                files.append(p)
            else:
                print(f"error: {a}: no such file or folder", file=sys.stderr)
                return 2
        expected: dict[str, set[str]] = {}
    else:
        problems += stale_generated()
        files, expected = shipped_files(), EXPECTED
        missing = [k for k in EXPECTED if not (ROOT / k).is_file()]
        problems += [f"{k}: listed in EXPECTED in tools/asam_qc.py but missing" for k in missing]
    if xqar_dir.exists() and (xqar_dir / ".asam-qc").is_file():
        shutil.rmtree(xqar_dir)
    xqar_dir.mkdir(parents=True, exist_ok=True)
    (xqar_dir / ".asam-qc").write_text("results of tools/asam_qc.py; rewritten on every run\n")
    results = run(files, args.jobs, xqar_dir)
    problems += verdict(results, expected)
    n_issues = sum(len(r["issues"]) for r in results)
    if args.json:
        Path(args.json).write_text(json.dumps({"files": [{**r, "file": shown(r["file"]), "xqar": shown(r["xqar"])} for r in results]}, indent=1) + "\n")
    for line in problems:
        print(line)
    if args.summary:
        print("\n".join(rule_summary(results)))
    n_xosc = sum(1 for f in files if f.suffix.lower() != ".xodr")
    print(f"ASAM quality checker: {len(files)} files ({n_xosc} .xosc, {len(files) - n_xosc} .xodr), {n_issues} issues"
          + (f" ({sum(len(v) for v in expected.values())} expected rules)" if expected else "")
          + f", {len(problems)} problems; {time.monotonic() - t0:.1f} s with -j {args.jobs}; results in {shown(str(xqar_dir))}/")
    return 0 if args.no_fail or not problems else 1


if __name__ == "__main__":
    sys.exit(main())
