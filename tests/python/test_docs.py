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
    # The blocks the drifts were in are generated (not only "some block somewhere").
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
