"""The documents' generated blocks (flc.docs, docs/README.md): the check passes on the committed
documents, and fails naming the file, the block and the first differing line when a committed
number in a block is changed."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from flc import docs
from flc.reproduction import ROOT


def test_every_generated_block_matches_the_code() -> None:
    out: list[str] = []
    assert docs.update(docs.documents(ROOT), check=True, out=out.append) == 0, "\n".join(out)
    # The blocks the issue's drifts were in are generated (not only "some block somewhere").
    commands = {b.command for p in docs.documents(ROOT) for b in docs.blocks(p)}
    for name in ("paper-tracking", "paper-cells paper", "reproduction-verdict", "platoon-brakedemo", "platoon-gamma", "sumo-replay",
                 "sumo-closed-loop", "sumo-platoon-outage", "sumo-platoon-join", "sumo-ssm"):
        assert f"{docs.PREFIX}{name}" in commands


def test_a_changed_number_fails_the_check_naming_file_block_and_line(tmp_path: Path) -> None:
    src = ROOT / "docs" / "paper-reproduction.md"
    doc = tmp_path / "paper-reproduction.md"
    shutil.copy(src, doc)
    text = doc.read_text(encoding="utf-8")
    (block,) = [b for b in docs.blocks(doc) if b.command.endswith("paper-cells paper")]
    lines = block.body.splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("| FLC 70 km/h"))
    num = lines[k].split("stop, ")[1].split(" m")[0]
    changed = f"{float(num) + 0.01:.2f}"
    lines[k] = lines[k].replace(f"stop, {num} m", f"stop, {changed} m", 1)
    start = text.index(block.body)
    doc.write_text(text[:start] + "".join(lines) + text[start + len(block.body):], encoding="utf-8")
    out: list[str] = []
    assert docs.update([doc], check=True, out=out.append) == 1
    (msg,) = out
    assert str(doc) in msg and f":{block.line}:" in msg
    assert "paper-cells paper" in msg and f"its line {k + 1}" in msg
    assert changed in msg and num in msg
    # Rewriting restores the code's text, byte for byte.
    assert docs.update([doc], check=False, out=lambda _: None) == 1
    assert doc.read_text(encoding="utf-8") == src.read_text(encoding="utf-8")


def test_a_block_without_end_or_with_an_unknown_generator_is_an_error(tmp_path: Path) -> None:
    doc = tmp_path / "x.md"
    doc.write_text(f"a\n{docs.HEADER}{docs.PREFIX}paper-tracking -->\n| x |\n", encoding="utf-8")
    with pytest.raises(docs.DocsError, match=r"x.md:2: block .*paper-tracking.* has no"):
        list(docs.blocks(doc))
    doc.write_text(f"{docs.HEADER}cat numbers.txt -->\n{docs.END}\n", encoding="utf-8")
    with pytest.raises(docs.DocsError, match="x.md:1: a generated block's header must read"):
        list(docs.blocks(doc))
    doc.write_text(f"{docs.HEADER}{docs.PREFIX}no-such-block -->\n{docs.END}\n", encoding="utf-8")
    with pytest.raises(docs.DocsError, match="unknown block `no-such-block`"):
        docs.update([doc], check=True, out=lambda _: None)


# ------------------------------------------------------------------ numbers in prose
# Prose outside the generated blocks states numbers too. These tests extract specific kinds of
# claim from the prose of README.md and docs/*.md and compare each with the committed data or
# generated block it restates, or with what the code outputs (docs/README.md, "Numbers in prose").

import json  # noqa: E402
import re  # noqa: E402

from flc import _flc  # noqa: E402

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SUITES = {s: json.loads((ROOT / "docs" / "standard-suites" / f"{s}.json").read_text(encoding="utf-8")) for s in ("ncap-ccr", "r157")}


def prose_paragraphs(path: Path) -> list[tuple[int, str]]:
    """``(first line, text)`` of every paragraph outside generated blocks, code fences and tables,
    its lines joined by spaces."""
    out: list[tuple[int, str]] = []
    cur: list[str] = []
    start = 0
    block = fence = False

    def flush() -> None:
        if cur:
            out.append((start, " ".join(cur)))
            cur.clear()

    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        s = line.strip()
        if block:
            block = not s.startswith(docs.END.strip())
            continue
        if s.startswith("```"):
            flush()
            fence = not fence
            continue
        if fence:
            continue
        if s.startswith(docs.HEADER.strip()):
            flush()
            block = True
            continue
        if not s or s.startswith("|") or s.startswith("#"):
            flush()
            continue
        if not cur:
            start = i
        cur.append(s)
    flush()
    return out


def sentences(text: str) -> list[str]:
    return re.split(r"(?<=[.;])\s+(?=[A-Z(*`])|;\s+", text)


def test_pass_counts_next_to_a_controller_match_the_suite_reports() -> None:
    passed = {(name, s["controller"]): (s["passed"], s["runs"]) for name, r in SUITES.items() for s in r["summary"]}
    runs_of = {}
    for name, r in SUITES.items():
        (n,) = {s["runs"] for s in r["summary"]}
        runs_of[n] = name
    assert len(runs_of) == len(SUITES), "two suites with the same number of runs: a count would not say which suite"
    controllers = set(_flc.controller_names())
    errors, checked = [], 0
    for doc in DOCS:
        for line, para in prose_paragraphs(doc):
            for sentence in sentences(para):
                for m in re.finditer(r"\b(\d+) ?/ ?(\d+)\b", sentence):
                    count, total = int(m.group(1)), int(m.group(2))
                    names = [c for c in re.findall(r"`([a-z0-9-]+)`", sentence[: m.start()]) if c in controllers]
                    if total not in runs_of or not names:
                        continue
                    suite, ctrl = runs_of[total], names[-1]
                    checked += 1
                    if passed[(suite, ctrl)] != (count, total):
                        got = passed[(suite, ctrl)]
                        errors.append(f"{doc.name}:{line}: `{ctrl}` {count}/{total}, but {suite}.json has {got[0]}/{got[1]}")
    assert not errors, "\n".join(errors)
    assert checked >= 3, f"only {checked} pass counts found: the extraction no longer finds the claims"


def _suite_para() -> str:
    (para,) = [p for _, p in prose_paragraphs(ROOT / "docs" / "standard-suites.md") if p.startswith("Reading the matrices")]
    return para


def _outcomes(suite: str, controller: str, case: str) -> list[tuple[dict, str]]:
    return [(r, r["outcome"]) for r in SUITES[suite]["results"] if r["controller"] == controller and r["case"] == case]


def test_the_cases_named_in_reading_the_matrices_match_the_reports() -> None:
    para = _suite_para()
    # "only the robust FLC v1 (`flc-robust-v1`) fails ... hits the stationary CCRs target from N km/h on"
    m = re.search(r"only the robust FLC v1 \(`flc-robust-v1`\) fails.*?CCRs target from (\d+) km/h on", para)
    assert m, para
    failing = {s["controller"] for s in SUITES["ncap-ccr"]["summary"] if s["passed"] < s["runs"]}
    assert failing == {"flc-robust-v1"}
    ccrs = _outcomes("ncap-ccr", "flc-robust-v1", "CCRs")
    hit = sorted(round(r["test_speed"] * 3.6) for r, o in ccrs if o == "collision")
    assert hit and hit[0] == int(m.group(1)) and hit == sorted(round(r["test_speed"] * 3.6) for r, _ in ccrs if r["test_speed"] * 3.6 >= hit[0] - 1e-6)
    # "the paper's FLC brakes harder than the 4.3_1 comfort limit behind a lead slowing at 2 m/s²"
    m = re.search(r"paper's FLC brakes harder than the 4\.3_1 comfort limit behind a lead slowing at (\d+) m/s², as RSS and CARLA do behind every 4\.3_1 lead", para)
    assert m, para
    flc_bad = {r["run"] for r, o in _outcomes("r157", "flc", "4.3_1") if o != "pass"}
    assert flc_bad and all(f"LeadDecel={m.group(1)} " in run for run in flc_bad)
    assert flc_bad == {r["run"] for r, _ in _outcomes("r157", "flc", "4.3_1") if f"LeadDecel={m.group(1)} " in r["run"]}
    for c in ("rss", "carla-behavior"):
        assert all(o == "uncomfortable" for _, o in _outcomes("r157", c, "4.3_1")), c
    # "(CARLA in 3 of the 6 4.4_1 runs, ACC and RSS in 1; Gipps and IDM in none) collide in the cut-ins"
    assert "(CARLA in 3 of the 6 4.4_1 runs, ACC and RSS in 1; Gipps and IDM in none) collide" in " ".join(para.split())
    for c, hits in (("carla-behavior", 3), ("acc", 1), ("rss", 1), ("gipps", 0), ("idm", 0)):
        out = [o for _, o in _outcomes("r157", c, "4.4_1")]
        assert len(out) == 6 and out.count("collision") == hits, (c, out)
    # "the PID follows the lead's V2V speed into the revealed stationary car of 4.5_1"
    assert "the PID follows the lead's V2V speed into the revealed stationary car of 4.5_1" in para
    assert all(o == "collision" for _, o in _outcomes("r157", "pid", "4.5_1"))
    # "the robust FLC v2 ... passes both suites"
    assert "robust FLC v2 (`docs/robust-flc.md`) passes both suites" in para
    assert all(s["passed"] == s["runs"] for r in SUITES.values() for s in r["summary"] if s["controller"] == "flc-robust")


def test_paper_clearances_in_prose_match_the_documents_paper_cells_block() -> None:
    errors, checked = [], 0
    for doc in DOCS:
        cells = [b for b in docs.blocks(doc) if b.command.split(docs.PREFIX)[-1].startswith("paper-cells")]
        if not cells:
            continue
        table = {(m.group(1), m.group(2)): m.group(3) for m in re.finditer(r"\| (FLC|PID) (\d+) km/h \| stop, (\d+\.\d+) m \|", cells[0].body)}
        for line, para in prose_paragraphs(doc):
            for m in re.finditer(r"\b(FLC|PID) at (\d+) km/h: (\d+\.\d+) m\b", para):
                checked += 1
                want = table.get((m.group(1), m.group(2)))
                if want is None or float(want) != float(m.group(3)):
                    errors.append(f"{doc.name}:{line}: {m.group(0)}, but the block says {want} m")
    assert not errors, "\n".join(errors)
    assert checked >= 1


def test_python_md_states_the_gym_action_space_and_every_extra() -> None:
    gym_mod = pytest.importorskip("flc.gym")
    text = " ".join(p for _, p in prose_paragraphs(ROOT / "docs" / "python.md"))
    raw = (ROOT / "docs" / "python.md").read_text(encoding="utf-8")
    m = re.search(r'action `"acceleration"`: shape 1 in `\[-max_brake, max_accel\]` of the ego\'s vehicle \(default\s+`\[(-?[\d.]+), (-?[\d.]+)\]` m/s²', raw)
    assert m, "the acceleration action's default range is no longer stated as the test expects"
    space = gym_mod.FollowingEnv(action="acceleration").action_space
    assert (float(m.group(1)), float(m.group(2))) == (float(space.low[0]), float(space.high[0]))
    doc = gym_mod.FollowingEnv.__doc__ or ""
    m = re.search(r"default ``\[(-?[\d.]+), (-?[\d.]+)\]``\)", doc)
    assert m and (float(m.group(1)), float(m.group(2))) == (float(space.low[0]), float(space.high[0]))
    tomllib = pytest.importorskip("tomllib")
    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]) - {"test"}
    assert extras <= set(re.findall(r"`flc\[(\w+)\]`", text)), extras - set(re.findall(r"`flc\[(\w+)\]`", text))


def test_run_counts_and_limits_in_help_and_docs_match_the_code(capsys: pytest.CaptureFixture[str]) -> None:
    from flc import __main__ as cli
    from flc import envelope

    runs = len(envelope.CONTROLLERS) * len(envelope.SPEEDS_KMH) * (len(envelope.LEAD_DECELS) + len(envelope.LATENCY_FRAMES))
    with pytest.raises(SystemExit):
        cli.main(["figures", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    m = re.search(r"skip the safety-envelope maps \(([\d ]+) runs", help_text)
    assert m and int(m.group(1).replace(" ", "")) == runs
    m = re.search(r"`python -m flc figures --out docs/figures` \(([\d ]+) runs", (ROOT / "docs" / "README.md").read_text(encoding="utf-8"))
    assert m and int(m.group(1).replace(" ", "")) == runs
    lo, hi = _flc.paper_speed_range_kmh()
    m = re.search(r"\| `speed_kmh` \| none \| \[([\d.]+), ([\d.]+)\] km/h", (ROOT / "docs" / "scenarios.md").read_text(encoding="utf-8"))
    assert m and (float(m.group(1)), float(m.group(2))) == (lo, hi)


def test_user_documents_cite_no_issue_numbers() -> None:
    # A reader cannot look them up. Generated blocks are exempt until regenerated (their labels
    # come from the code that writes them).
    found = [
        f"{doc.name}:{line}: {m.group(0)}"
        for doc in DOCS
        for line, para in prose_paragraphs(doc)
        for m in re.finditer(r"\b[Ii]ssues? #?\d+", para)
    ]
    assert not found, "\n".join(found)
