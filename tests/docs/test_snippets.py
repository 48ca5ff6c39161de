"""Every code snippet of README.md and docs/**/*.md runs, and shows what it prints.

The fenced blocks of each page are taken in order, in one temporary working
directory per page that holds ``scenes/`` and ``scripts/`` (links to the
repository's), so that snippets use the paths a reader types at the top of a
clone. A block's info string says what it is:

``python``
    Run, top to bottom in one namespace per page. An ``output`` block right
    after it is compared with what it printed.
``output``
    The printed output of the block before it. ``...`` stands for any text
    (timings, long tables); trailing spaces do not count.
``yaml``
    A scene when it has ``analysis:``: checked as ``contin check`` checks it
    (schema, the built model, the analysis's own checks). With
    ``scene=PATH`` its sections replace those of that scene file first
    (an excerpt such as an ``analysis`` section alone). Other YAML must load.
``console``
    ``$ command`` lines (a trailing ``\\`` continues one), each followed by the
    output it prints, compared as for ``output`` when shown. ``contin ...``
    runs in this process (``contin.app.cli.main``) and must exit with 0;
    ``python scripts/...`` must name a script that exists (the scripts run in
    ``tests/scripts``); ``pip install`` and ``python -m pytest`` are the set-up
    and are checked against ``.ci/run`` elsewhere (``test_readme.py``).
``text``
    Not code (formulas, file excerpts): not run.

Flags come in an HTML comment on the line before the fence (Markdown renderers show
nothing of it, and they read an info string of one word only):
``<!-- snippet: slow -->`` runs the block only in the slow tier (in the default tier
a ``python`` block is compiled and a ``console`` block's ``contin run``/``sweep``
lines are checked with ``contin check`` and their ``--set`` values);
``<!-- snippet: skip -->`` never runs it (a cluster's commands, runs of many
minutes), with the same checks; ``<!-- snippet: scene=PATH -->`` is the ``scene=``
of a ``yaml`` block; ``status=N`` the exit status a ``console`` block's
``contin`` commands end with when it is not 0 (a run that falls short, and
says so). Keep ``slow`` and ``skip`` rare.

In the slow tier a ``contin run scenes/<scene> -o DIR`` line with nothing more, for a scene of
``SHARED_RUNS`` (the main job, shown on four pages), takes the session's one run of that command
(``scene_run`` in ``tests/conftest.py``, which the result tests read too): its directory is copied
to ``DIR`` and what it printed is compared as a run of the page's own would be.
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
LANGUAGES = ("python", "output", "yaml", "console", "text")
FLAGS = ("slow", "skip")
FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})(?P<info>.*)$")
MARK = re.compile(r"^\s*<!--\s*snippet:(?P<words>[^>]*)-->\s*$")


@dataclass
class Block:
    """One fenced block of a page."""

    page: Path
    line: int
    language: str
    flags: tuple
    options: dict
    text: str

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def blocks_of(page: Path) -> list[Block]:
    """The fenced blocks of a Markdown page, in order (indented fences inside list items too)."""
    lines = page.read_text(encoding="utf-8").splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence = len(m["indent"]), m["fence"]
        words = m["info"].split()
        assert len(words) <= 1, (f"{page.relative_to(ROOT)}:{i + 1}: an info string of one word (Markdown reads no "
                                 f"more); flags go in a '<!-- snippet: ... -->' line before the fence")
        mark = MARK.match(lines[i - 1]) if i else None
        words += mark["words"].split() if mark else []
        start, body = i + 1, []
        i += 1
        while i < len(lines) and not (lines[i].strip().startswith(fence) and lines[i].strip().strip(fence[0]) == ""):
            body.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i])
            i += 1
        i += 1
        language = words[0] if words else ""
        flags = tuple(w for w in words[1:] if "=" not in w)
        options = dict(w.split("=", 1) for w in words[1:] if "=" in w)
        out.append(Block(page, start, language, flags, options, "\n".join(body) + "\n"))
    return out


def _pattern(expected: str) -> re.Pattern:
    """``expected`` as a regular expression: ``...`` matches any text, trailing spaces are dropped."""
    text = "\n".join(line.rstrip() for line in expected.strip("\n").splitlines())
    return re.compile(".*?".join(re.escape(part) for part in text.split("...")), re.S)


def assert_output(expected: str, found: str, where: str) -> None:
    found = "\n".join(line.rstrip() for line in found.strip("\n").splitlines())
    assert _pattern(expected).fullmatch(found), f"{where}: the output shown differs from\n{found}"


#: scenes whose plain ``contin run scenes/<name> -o DIR`` a page takes from the session's shared run (the main job)
SHARED_RUNS = ("rotor_f0_05.yaml",)


@dataclass
class Page:
    """The state of one page's run: its namespace, the last python block's output, the session's shared runs."""

    run_slow: bool
    scene_run: object = None
    namespace: dict = field(default_factory=lambda: {"__name__": "__snippet__"})
    printed: str | None = None


def _run_python(block: Block, page: Page) -> None:
    # as a reader's interpreter runs it: not under this file's ``from __future__ import annotations``
    code = compile(block.text, block.where, "exec", dont_inherit=True)
    if "skip" in block.flags or ("slow" in block.flags and not page.run_slow):
        return
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        exec(code, page.namespace)  # noqa: S102  (the documentation's own code)
    page.printed = buf.getvalue()


def _check_yaml(block: Block) -> None:
    from contin.scene.build import build_model
    from contin.scene.parse import SceneLoader, scene_from_data
    from contin.scene.registry import check_scene

    data = yaml.load(block.text, Loader=SceneLoader)  # noqa: S506  (a SafeLoader subclass)
    if "scene" in block.options:
        base = yaml.load((ROOT / block.options["scene"]).read_text(encoding="utf-8"), Loader=SceneLoader)  # noqa: S506
        data = {**base, **data}
    if not isinstance(data, dict) or "analysis" not in data:
        return
    # an excerpt of a scene file is read as that file (its relative paths, such as a rotor file, are its own)
    scene = scene_from_data(data, str(ROOT / block.options["scene"]) if "scene" in block.options else block.where)
    check_scene(scene, build_model(scene))


def commands_of(block: Block) -> list[tuple[int, str, str]]:
    """``(line, command, output shown)`` of a console block."""
    out: list = []
    lines = block.text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.startswith("$ "):
            if out:
                out[-1][2].append(line)
            else:
                assert not line.strip(), f"{block.where}: output before the first '$ ' line"
            i += 1
            continue
        cmd, first = line[2:], i
        while cmd.endswith("\\") and i + 1 < len(lines):
            i += 1
            cmd = cmd[:-1] + " " + lines[i].strip()
        out.append((block.line + first, cmd, []))
        i += 1
    return [(n, cmd, "\n".join(shown)) for n, cmd, shown in out]


def _contin(argv: list, where: str, expected: int = 0) -> str:
    from contin.app.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = main(argv)
    assert status == expected, f"{where}: `contin {' '.join(argv)}` exited with {status}:\n{buf.getvalue()[-2000:]}"
    return buf.getvalue()


def _shared_run(args: list, page: Page, expected: int) -> str | None:
    """What ``contin <args>`` printed, taken from the session's run of the same command (its directory copied to
    the page's ``-o``), or None when the command is not one of ``SHARED_RUNS`` run plainly."""
    if page.scene_run is None or expected != 0 or len(args) != 4 or args[0] != "run" or args[2] != "-o":
        return None
    scene, dest = Path(args[1]), Path(args[3])
    if scene.parent.as_posix() != "scenes" or scene.name not in SHARED_RUNS or dest.exists():
        return None
    out = page.scene_run(scene.name)  # exit status 0, asserted there
    shutil.copytree(out, dest)
    return page.scene_run.printed(scene.name).replace(str(out), args[3])


def _check_only(argv: list, where: str) -> None:
    """What can be checked of a command that is not run: the scene and its ``--set`` values."""
    if argv and argv[0] in ("run", "sweep"):
        scene = next(a for a in argv[1:] if not a.startswith("-"))
        sets = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a == "--set"]
        _contin(["check", scene, *[x for s in sets for x in ("--set", s)]], where)


def _run_console(block: Block, page: Page) -> None:
    run = not ("skip" in block.flags or ("slow" in block.flags and not page.run_slow))
    for line, cmd, shown in commands_of(block):
        where = f"{block.page.relative_to(ROOT)}:{line}"
        for part in cmd.split("&&"):
            argv = shlex.split(part, comments=True)
            if not argv:
                continue
            if argv[0] == "contin" or argv[:3] == ["python", "-m", "contin"]:
                args = argv[1:] if argv[0] == "contin" else argv[3:]
            elif argv[0] == "python" and "contin" in argv and argv[argv.index("contin") - 1] == "-m":
                args = argv[argv.index("contin") + 1:]  # under a profiler: python -m cProfile ... -m contin ...
            elif argv[0] == "python" and len(argv) > 1 and argv[1].startswith("scripts/"):
                assert (ROOT / argv[1]).is_file(), f"{where}: no script {argv[1]}"
                continue
            elif argv[:2] == ["pip", "install"] or argv[:4] == ["python", "-m", "pip", "install"] or \
                    argv[:3] == ["python", "-m", "pytest"]:
                continue
            else:
                assert "skip" in block.flags, f"{where}: a console block runs only contin, scripts and the set-up"
                continue
            if run:
                expected = int(block.options.get("status", 0))
                out = _shared_run(args, page, expected)
                if out is None:
                    out = _contin(args, where, expected)
                if shown.strip():
                    assert_output(shown, out, where)
            else:
                _check_only(args, where)


def run_page(page_path: Path, run_slow: bool, scene_run=None) -> None:
    page = Page(run_slow, scene_run)
    for block in blocks_of(page_path):
        assert block.language in LANGUAGES, (
            f"{block.where}: a fenced block's info string starts with one of {LANGUAGES}, found {block.language!r}")
        assert set(block.flags) <= set(FLAGS), f"{block.where}: flags are among {FLAGS}, found {block.flags}"
        if block.language == "python":
            _run_python(block, page)
        elif block.language == "output":
            if page.printed is not None:
                assert_output(block.text, page.printed, block.where)
            page.printed = None
        elif block.language == "yaml":
            _check_yaml(block)
        elif block.language == "console":
            _run_console(block, page)


def _workdir(tmp_path: Path, monkeypatch) -> None:
    for name in ("scenes", "scripts"):
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")


def _name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


WITH_SNIPPETS = [p for p in PAGES if any(b.language != "text" for b in blocks_of(p))]
WITH_SLOW = [p for p in WITH_SNIPPETS if any("slow" in b.flags for b in blocks_of(p))]


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """The page's working directory; the model catalogue as it was before (a page may register a model)."""
    import importlib

    from contin.model.catalog import BUILTIN_MODELS, MODELS

    _workdir(tmp_path, monkeypatch)
    importlib.import_module(BUILTIN_MODELS)  # the catalogue filled before it is copied
    models = dict(MODELS)
    yield tmp_path
    MODELS.clear()
    MODELS.update(models)
    import matplotlib.pyplot as plt

    plt.close("all")


def _section(page: Path) -> str:
    """``docs/<section>`` of a page, or ``""`` for the README and the pages at the top of docs/."""
    parts = page.relative_to(ROOT).parts
    return "/".join(parts[:2]) if len(parts) > 2 else ""


# one class per section: the test workers (pytest-xdist, --dist loadscope) take the sections apart
class _Section:
    section = ""

    def test_page_snippets_run(self, page, workdir):
        run_page(page, run_slow=False)


def pytest_generate_tests(metafunc):
    if metafunc.cls is not None and issubclass(metafunc.cls, _Section):
        pages = [p for p in WITH_SNIPPETS if _section(p) == metafunc.cls.section]
        metafunc.parametrize("page", pages, ids=_name)
    if metafunc.cls is not None and issubclass(metafunc.cls, _SlowSection):
        pages = [p for p in WITH_SLOW if _section(p) == metafunc.cls.section]
        metafunc.parametrize("slow_page", pages, ids=_name)


class TestFrontPages(_Section):
    section = ""


class TestTutorials(_Section):
    section = "docs/tutorials"


class TestHowTo(_Section):
    section = "docs/howto"


class TestReference(_Section):
    section = "docs/reference"


class TestTheory(_Section):
    section = "docs/theory"


class TestValidation(_Section):
    section = "docs/validation"


def test_every_page_with_snippets_has_its_class():
    assert {_section(p) for p in WITH_SNIPPETS} <= {c.section for c in _Section.__subclasses__()}


# each page with slow blocks runs whole in the slow tier; its default run above checks those blocks' scenes;
# one class per section here too, so that the test workers take the long pages apart
class _SlowSection:
    section = ""

    @pytest.mark.slow
    def test_page_snippets_run_with_the_slow_blocks(self, slow_page, workdir, scene_run):
        run_page(slow_page, run_slow=True, scene_run=scene_run)


class TestFrontPagesSlow(_SlowSection):
    section = ""


class TestTutorialsSlow(_SlowSection):
    section = "docs/tutorials"
    pytestmark = pytest.mark.longest  # the rotor tutorial's runs: left out of CI's slow run for its time


class TestHowToSlow(_SlowSection):
    section = "docs/howto"


class TestValidationSlow(_SlowSection):
    section = "docs/validation"


def test_every_page_with_slow_blocks_has_its_slow_class():
    assert {_section(p) for p in WITH_SLOW} <= {c.section for c in _SlowSection.__subclasses__()}


def test_the_parser_reads_fences_flags_and_console_output(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("text\n\n- item\n\n  <!-- snippet: slow -->\n  ```console\n  $ contin run a.yaml \\\n      -o b\n  shown\n  ```\n\n"
                    "```python\nprint(1)\n```\n\n```output\n1\n```\n", encoding="utf-8")
    blocks = [Block(ROOT / "README.md", b.line, b.language, b.flags, b.options, b.text) for b in blocks_of(page)]
    assert [(b.language, b.flags) for b in blocks] == [("console", ("slow",)), ("python", ()), ("output", ())]
    assert commands_of(blocks[0]) == [(blocks[0].line, "contin run a.yaml  -o b", "shown")]
    assert_output("a ... c\n", "a b c  \n", "here")
    with pytest.raises(AssertionError):
        assert_output("a ... c", "a b d", "here")


def test_a_plain_run_of_the_main_job_takes_the_shared_run(tmp_path, monkeypatch):
    # a stand-in for the session's runs: its directory and what it printed, naming that directory
    shared = tmp_path / "shared" / "out"
    shared.mkdir(parents=True)
    (shared / "summary.json").write_text("{}")

    asked = []

    class Runs:
        def __call__(self, name):
            asked.append(name)
            return shared

        def printed(self, name):
            return f"branch 0 (nu=1): 47 points\nresults in {shared} (1.00 s)\n"

    monkeypatch.chdir(tmp_path)
    page = Page(True, Runs())
    assert _shared_run(["run", "scenes/rotor_f0_05.yaml", "-o", "results/rotor"], page, 0) == \
        "branch 0 (nu=1): 47 points\nresults in results/rotor (1.00 s)\n"
    assert (tmp_path / "results" / "rotor" / "summary.json").is_file() and asked == ["rotor_f0_05.yaml"]
    # anything more than the plain command, another scene, another exit status, an existing directory: run itself
    for args, status in ((["run", "scenes/rotor_f0_05.yaml", "-o", "x", "--set", "analysis.harmonics=5"], 0),
                         (["run", "scenes/duffing.yaml", "-o", "x"], 0),
                         (["run", "scenes/rotor_f0_05.yaml", "-o", "x"], 1),
                         (["run", "scenes/rotor_f0_05.yaml", "-o", "results/rotor"], 0)):
        assert _shared_run(args, page, status) is None
    assert _shared_run(["run", "scenes/rotor_f0_05.yaml", "-o", "x"], Page(True), 0) is None
