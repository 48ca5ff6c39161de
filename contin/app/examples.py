"""The example scenes that ship with contin: listed, found by name, copied.

The scenes of the source tree's ``scenes/`` and the files they read
(``scenes/data/``) install as the package ``contin.scenes``, so that after a
plain ``pip install`` ``contin run duffing -o out`` runs the shipped
``duffing.yaml`` and ``contin examples --copy DIR`` gives a directory of scenes
to edit. A scene reads its data files relative to itself
(``model.file: data/rig_001.npz``), which holds in the installed package and in
a copy alike.
"""

from __future__ import annotations

import difflib
import os
import re
import stat
import textwrap
from pathlib import Path

from contin.scene.schema import SceneError
from contin.util.safe_files import replace_file

__all__ = ["EXAMPLE_SUFFIX", "examples_dir", "example_names", "example_files", "find_scene", "describe",
           "listing", "copy_examples"]

#: the suffix of a scene file; ``contin run duffing`` and ``contin run duffing.yaml`` name the same example
EXAMPLE_SUFFIX = ".yaml"
#: the subdirectory of the files scenes read
DATA_DIR = "data"
#: width of a description in the listing (one line each)
DESCRIPTION_WIDTH = 100
#: the end of a sentence: a full stop before a capital, not that of "Fig. 8", "sec. 3", "eq. 21"
_SENTENCE_END = re.compile(r"(?<!\bFig)(?<!\bfig)(?<!\bsec)(?<!\bSec)(?<!\beq)(?<!\bEq)(?<!\bex)\.\s+(?=[A-Z])")


def examples_dir() -> Path:
    """The directory of the installed ``contin.scenes``.

    Raises
    ------
    contin.scene.schema.SceneError
        When the package is not installed as files (a zip archive): a scene
        reads its data files beside it, so the examples need a directory.
    """
    from importlib.resources import files

    root = files("contin.scenes")
    if not isinstance(root, Path) or not root.is_dir():
        raise SceneError("contin.scenes", "the example scenes installed as files in a directory", str(root))
    return root


def _regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def example_names() -> list[str]:
    """The names of the shipped scenes (``duffing``, ...), sorted."""
    root = examples_dir()
    return sorted(p.name[:-len(EXAMPLE_SUFFIX)] for p in root.iterdir()
                  if p.name.endswith(EXAMPLE_SUFFIX) and not p.name.startswith(".") and _regular(p))


def example_files() -> list[tuple[str, Path]]:
    """``(relative path, installed file)`` of every scene and data file, scenes first, sorted."""
    root = examples_dir()
    out = [(n + EXAMPLE_SUFFIX, root / (n + EXAMPLE_SUFFIX)) for n in example_names()]
    data = root / DATA_DIR
    if data.is_dir():
        out += [(f"{DATA_DIR}/{p.name}", p) for p in sorted(data.iterdir())
                if _regular(p) and not p.name.startswith(".") and p.name != "__init__.py"]
    return out


def find_scene(arg: str) -> str:
    """The scene file ``contin run ARG`` and ``contin check ARG`` read.

    ``ARG`` is a path when it holds a path separator or when a file (not a
    directory) of that name exists in the current directory; otherwise it is
    the name of a shipped example, with or without ``.yaml``.

    Parameters
    ----------
    arg : str
        The command line's scene argument.

    Returns
    -------
    str
        ``arg`` itself, or the path of the installed example.

    Raises
    ------
    contin.scene.schema.SceneError
        ``arg`` is neither a file nor the name of an example (the closest
        names are suggested).
    """
    seps = {os.sep, "/"} | ({os.altsep} if os.altsep else set())
    if not arg or any(s in arg for s in seps) or arg in (".", ".."):
        return arg
    if os.path.lexists(arg) and not os.path.isdir(arg):
        return arg  # a file here is what the user means, even one named like an example
    name = arg[:-len(EXAMPLE_SUFFIX)] if arg.endswith(EXAMPLE_SUFFIX) else arg
    names = example_names()
    if name in names:
        return str(examples_dir() / (name + EXAMPLE_SUFFIX))
    close = difflib.get_close_matches(name, names, n=3)
    hint = f" (did you mean {', '.join(close)}?)" if close else ""
    raise SceneError(arg, "a scene file, or the name of an example that ships with contin (`contin examples` "
                     "lists them); it is neither", None, hint=hint)


def describe(path: Path) -> str:
    """One line on a scene: the first sentence of its opening comment, else its ``output.title``, else ``""``."""
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    comment = []
    for line in lines:
        s = line.strip()
        if not s.startswith("#"):
            break
        comment.append(s.lstrip("#").strip())
    text = " ".join(c for c in comment if c)
    if not text:
        import yaml

        try:
            data = yaml.safe_load("\n".join(lines))
            title = (data.get("output") or {}).get("title") if isinstance(data, dict) else None
        except yaml.YAMLError:
            title = None
        text = title if isinstance(title, str) else ""
    sentence = _SENTENCE_END.split(text)[0].rstrip(".")
    return textwrap.shorten(sentence, DESCRIPTION_WIDTH, placeholder=" ...") if sentence else ""


def listing() -> list[str]:
    """``contin examples``: one line per shipped scene, its name and what it is."""
    names = example_names()
    width = max((len(n) for n in names), default=0)
    root = examples_dir()
    return [f"{n:<{width}}  {describe(root / (n + EXAMPLE_SUFFIX))}".rstrip() for n in names]


def copy_examples(dest, force: bool = False) -> list[Path]:
    """Copy every shipped scene and its data files into ``dest`` (``contin examples --copy DIR``).

    ``dest`` and its ``data/`` are made if absent. Nothing is written unless
    every target is free, or ``force`` is given; each file is written whole
    through a temporary file (:func:`contin.util.safe_files.replace_file`), so
    a link or a special file where a file goes is refused even with ``force``.

    Parameters
    ----------
    dest : path
        A directory, new or existing (a link to one is followed: the user named it).
    force : bool
        Replace files of the same names.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    contin.scene.schema.SceneError
        ``dest`` is a file, ``dest/data`` is not a plain directory, or files of
        the examples' names exist and ``force`` is not given (they are named;
        nothing is written).
    OSError
        Naming the file that could not be written (``UnsafeTarget`` for a link).
    """
    dest = Path(dest)
    if os.path.exists(dest) and not os.path.isdir(dest):
        raise SceneError("--copy", "a directory for the examples (new or existing)", str(dest),
                         hint=" (a file of that name exists)")
    files = example_files()
    data = dest / DATA_DIR
    if any(rel.startswith(DATA_DIR + "/") for rel, _ in files) and os.path.lexists(data):
        # a link here would send the data files somewhere else than DIR
        if not stat.S_ISDIR(os.lstat(data).st_mode):
            raise SceneError("--copy", f"{DATA_DIR}/ in the directory to be a plain directory (not a link or a "
                             "file)", str(data))
    taken = [rel for rel, _ in files if os.path.lexists(dest / rel)]
    if taken and not force:
        shown = ", ".join(taken[:5]) + (f" and {len(taken) - 5} more" if len(taken) > 5 else "")
        raise SceneError("--copy", "a directory without files of the examples' names (or --force to replace "
                         "them)", str(dest), hint=f"; it holds {shown}; nothing was copied")
    written = []
    for rel, src in files:
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        content = src.read_bytes()
        replace_file(target, lambda fh, content=content: fh.write(content), binary=True)
        written.append(target)
    return written
