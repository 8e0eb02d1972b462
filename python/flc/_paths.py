"""Where the package's data and, for the developer commands, the source tree are.

The data the package needs at run time ships inside it (``flc/data``, the one copy in the
repository; ``scenarios/suites`` and ``sweeps/paper-reproduction*`` are links to it): the
standard suites (:data:`SUITES`) and the paper reproduction map (:data:`REPRODUCTION`). They are
found from the package, never from the working directory.

The commands that read or write the documents (``python -m flc docs``, the tables they include)
need the source tree: :func:`source_root` finds it (``$FLC_SOURCE_TREE``, else the tree this
package runs from, else a checkout around the working directory) and :func:`require_source_tree`
says so when there is none.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

#: The package's data folder.
DATA = Path(__file__).resolve().parent / "data"
#: The standard suites (``docs/standard-suites.md``): one folder with a ``suite.toml`` each.
SUITES = DATA / "suites"
#: The paper reproduction map: ``paper-reproduction.toml`` and its committed CSVs.
REPRODUCTION = DATA / "reproduction"

#: Environment variable naming the source tree for the developer commands.
SOURCE_TREE_ENV = "FLC_SOURCE_TREE"


class SourceTreeError(RuntimeError):
    """A command needs the flc source tree (the documents, the sweep files) and none was found."""


def _is_source_tree(d: Path) -> bool:
    return (d / "Cargo.toml").is_file() and (d / "crates" / "flc-sim").is_dir() and (d / "docs").is_dir() and (d / "README.md").is_file()


def source_root() -> Optional[Path]:
    """The flc source tree: ``$FLC_SOURCE_TREE`` if set, else the tree this package runs from (a
    ``maturin develop`` install), else the checkout holding the working directory; ``None`` if
    there is none (an installed package run elsewhere)."""
    env = os.environ.get(SOURCE_TREE_ENV)
    if env:
        return Path(env).resolve()
    own = Path(__file__).resolve().parents[2]
    if _is_source_tree(own):
        return own
    cwd = Path.cwd().resolve()
    return next((d for d in [cwd, *cwd.parents] if _is_source_tree(d)), None)


def require_source_tree(what: str) -> Path:
    """:func:`source_root`, or :class:`SourceTreeError` saying that ``what`` needs it."""
    root = source_root()
    if root is None:
        raise SourceTreeError(
            f"{what} needs the flc source tree (README.md, docs/, sweeps/) and none was found: run it inside a checkout, "
            f"or name one with --root DIR (or ${SOURCE_TREE_ENV})"
        )
    if not _is_source_tree(root):
        raise SourceTreeError(f"{what}: {root} is not an flc source tree (no Cargo.toml, crates/flc-sim, docs/ and README.md)")
    return root
