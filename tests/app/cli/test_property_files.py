"""Property tests (hypothesis) on the edges of YAML and of the file system.

Random scene texts given to ``contin check``, and a finished result directory
with random damage given to ``contin run --resume`` and ``contin plot``: each
call ends with a clean ``contin: error:`` message or a correct result, never
a traceback. The commands run in this process (``contin.app.cli.main``), so an
exception escaping ``main`` is what the shell would print as a traceback.

The inputs once found escaping are kept below as ordinary tests
(each was a traceback before it was fixed); those not fixed yet would be listed
in :data:`KNOWN_ESCAPES`, ``xfail(strict=True)``, and passed over by the
properties, so that a new escape is still reported.
"""

from __future__ import annotations

import csv
import json
import re
import shutil
import stat
import traceback
import uuid
from pathlib import Path

import pytest
from conftest import no_hang
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st

from conftest import fuzz_examples
from test_hostile_files import DUFFING, FAST, run

import contin
from contin.app.cli import main

ROOT = Path(__file__).resolve().parents[3]
PACKAGE = str(Path(contin.__file__).resolve().parent)
#: a cheap run: one harmonic, no stability, half the usual range (16 points, about a second)
CHEAP = [*FAST, "--set", "analysis.stability=none", "--set", "analysis.range=[0.5, 1.5]"]
VALID = [(ROOT / "scenes" / name).read_text(encoding="utf-8")
         for name in ("duffing.yaml", "custom_duffing.yaml", "gap_oscillator.yaml")]
RESULT_FILES = ["summary.json", "state.jsonl", "branches.csv", "special_points.csv"]
EXIT_CODES = {0, 1, 2, 130}
PROPERTY = settings(max_examples=fuzz_examples(100), deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                           HealthCheck.data_too_large])

#: Escapes found by these properties and not fixed yet: (exception type, contin module, function it is raised
#: in) -> what. The properties pass over exactly these; each gets an xfail(strict=True) reproducer below.
KNOWN_ESCAPES: dict = {}


def known_escape(exc: BaseException) -> str | None:
    """The entry of :data:`KNOWN_ESCAPES` that ``exc`` is, or None (judged by the innermost contin frame)."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename.startswith(PACKAGE)]
    if not frames:
        return None
    return KNOWN_ESCAPES.get((type(exc).__name__, Path(frames[-1].filename).stem, frames[-1].name))


def cli(argv, capsys, what: str):
    """``run`` of test_hostile_files (exit code and the message on one line, no traceback printed) with the
    input described in the failure when an exception escapes ``main``; None for a known escape."""
    try:
        with no_hang(120):
            return run(argv, capsys)
    except Exception as exc:  # noqa: BLE001  (the point of the test)
        capsys.readouterr()
        if known_escape(exc):
            event(f"known escape: {known_escape(exc)}")
            return None
        raise AssertionError(f"contin {' '.join(map(str, argv))}: {type(exc).__name__} escaped: {exc}\n"
                             f"--- input ---\n{what}") from exc


def assert_clean(code: int, err: str, codes=EXIT_CODES):
    assert code in codes, (code, err)
    if code != 0:
        # one message (wrapped at 100 columns, so a few lines at most), not a dump
        assert err.startswith("contin: "), err
        assert len(err) < 2000, err


# ------------------------------------------------------------------ (a) scene texts
NUMBER = re.compile(r"(?<![\w.])\d+(\.\d+)?(?![\w.])")
HUGE = ["1.0e+400", "-1.0e+999", "1e400", "9" * 40, "9" * 400, "9" * 5000, "0x" + "f" * 60, "0o777", "1_000",
        ".nan", "-.inf", "1e-400", "0.0000000000000000000000000000000001"]


@st.composite
def edited_scene(draw):
    """A valid scene with one edit at a random place."""
    text = draw(st.sampled_from(VALID))
    kind = draw(st.sampled_from(["truncate", "insert", "tab", "duplicate_line", "huge_number", "delete_chars"]))
    if kind == "truncate":
        return text[:draw(st.integers(0, len(text)))]
    if kind in ("insert", "tab"):
        at = draw(st.integers(0, len(text)))
        piece = "\t" if kind == "tab" else draw(st.text(max_size=12))
        return text[:at] + piece + text[at:]
    if kind == "delete_chars":
        at = draw(st.integers(0, len(text)))
        return text[:at] + text[at + draw(st.integers(1, 5)):]
    lines = text.splitlines(keepends=True)
    if kind == "duplicate_line":  # often a key given twice in one mapping
        i, j = draw(st.integers(0, len(lines) - 1)), draw(st.integers(0, len(lines)))
        lines.insert(j, lines[i])
        return "".join(lines)
    spans = [m.span() for m in NUMBER.finditer(text)]
    a, b = draw(st.sampled_from(spans))
    return text[:a] + draw(st.sampled_from(HUGE)) + text[b:]


@st.composite
def aliased_scene(draw):
    """Anchors, aliases and merges: defined, undefined, recursive, or nested."""
    width, depth = draw(st.integers(1, 9)), draw(st.integers(1, 9))
    pieces = [
        "base: &b {builtin: duffing}\nmodel: *b\n",
        "model: &m {builtin: duffing, options: *m}\n",
        "model: *nowhere\n",
        "p: &p {m: 1, c: 0.1}\nmodel: {builtin: duffing, parameters: {<<: *p, c: 0.2}}\n",
        "p: &p [1, 2]\nmodel: {builtin: duffing, parameters: {<<: *p}}\n",
        "l0: &l0 [a]\n" + "".join(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]\n" for i in range(1, depth))
        + f"model: {{builtin: duffing, options: {{x: *l{depth - 1}}}}}\n",
        "analysis: &a {type: frequency_response, range: [0.5, 2.0], harmonics: 1}\nmodel: {builtin: duffing}\n"
        "output: *a\n",
    ]
    return draw(st.sampled_from(pieces)) + draw(st.sampled_from(["", "analysis: {type: frequency_response, "
                                                                     "range: [0.5, 2.0]}\n"]))


@st.composite
def nested_scene(draw):
    """Flow or block nesting from a few levels to thousands, as the whole text or under a key."""
    n = draw(st.one_of(st.integers(1, 40), st.integers(40, 3000)))
    kind = draw(st.sampled_from(["list", "map", "block_map", "block_list"]))
    if kind == "list":
        body = "[" * n + "1" + "]" * n
    elif kind == "map":
        body = "{a: " * n + "1" + "}" * n
    elif kind == "block_map":
        body = "\n" + "".join("  " * (i + 1) + "a:\n" for i in range(min(n, 400))) + "  " * (min(n, 400) + 1) + "1"
    else:
        body = "- " * n + "1"
    where = draw(st.sampled_from(["", "model: ", "model: {builtin: duffing, options: {x: 0}}\nanalysis: "]))
    if kind == "block_map" and not where:
        where = "a:"  # a block mapping cannot start the text with a line break and an indented key
    return where + body + "\n"


SCENE_TEXTS = st.one_of(
    st.binary(max_size=300),
    st.text(max_size=200),
    st.text(alphabet=st.characters(codec="utf-8"), max_size=60).map(lambda t: VALID[0] + t),
    edited_scene(), edited_scene(),
    aliased_scene(),
    nested_scene(),
)


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("property_files")


@PROPERTY
@given(text=SCENE_TEXTS)
def test_random_scene_texts_give_a_clean_check(scratch, capsys, text):
    path = scratch / f"{uuid.uuid4().hex}.yaml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
    try:
        result = cli(["check", str(path)], capsys, repr(text[:3000]))
    finally:
        path.unlink()
    if result is not None:
        assert_clean(*result, codes={0, 2})


# ------------------------------------------------------------------ (b) result directories
@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished run of the Duffing scene at :data:`CHEAP` settings, made once; copied, never changed."""
    out = tmp_path_factory.mktemp("finished") / "out"
    assert main(["run", DUFFING, "-o", str(out), *CHEAP]) == 0
    assert json.loads((out / "summary.json").read_text())["status"] == "complete"
    return out


def mark_interrupted(out: Path, keep: int | None = None):
    """As a run killed after ``keep`` lines of state.jsonl (what --resume continues).

    By default just after its engine line but one: the earliest line a killed run resumes from (the engine
    states of the last two steps are held; a cut before them has nothing to resume, and starts again).
    """
    summary = json.loads((out / "summary.json").read_text())
    summary["status"] = "interrupted"
    (out / "summary.json").write_text(json.dumps(summary))
    lines = (out / "state.jsonl").read_text().splitlines(keepends=True)
    if keep is None:
        keep = [i for i, line in enumerate(lines) if line.startswith('{"type": "engine"')][-2] + 1
    (out / "state.jsonl").write_text("".join(lines[:keep]))


def damage(out: Path, name: str, how: str, fraction: float, junk: bytes):
    path = out / name
    if not path.is_file():
        return  # damaged already (deleted or made a directory)
    if how == "truncate":
        data = path.read_bytes()
        path.write_bytes(data[:int(len(data) * fraction)])
    elif how == "delete":
        path.unlink()
    elif how == "random_bytes":
        path.write_bytes(junk)
    elif how == "directory":
        path.unlink()
        path.mkdir()
        (path / "inside").write_text("x")
    elif how == "chmod_000":
        path.chmod(0)  # unreadable (except by root, to whom this is no damage)
    elif how == "not_utf8":
        path.write_bytes(b"\xe9t\xe9 " + junk)
    elif how == "json_not_object":
        path.write_text('[1, 2]\n"text"\n')
    elif how == "json_missing_keys":  # an object, but not the one contin writes there
        path.write_text('{"type": "point", "row": 0, "branch": 0}\n')


DAMAGE = st.tuples(st.sampled_from(RESULT_FILES),
                   st.sampled_from(["truncate", "delete", "random_bytes", "directory", "chmod_000", "not_utf8",
                                    "json_not_object", "json_missing_keys"]),
                   st.floats(0.0, 1.0), st.binary(max_size=120))


def consistent(out: Path):
    """summary.json parses and says complete; branches.csv has one row per branch point it counts."""
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["status"] == "complete", summary["status"]
    with open(out / "branches.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == sum(b["points"] for b in summary["analysis"]["branches"])


def restore_modes(out: Path):
    for p in [out, *out.rglob("*")]:
        if not p.is_symlink():
            p.chmod(stat.S_IRWXU if p.is_dir() else stat.S_IRUSR | stat.S_IWUSR)


# each example is a resume and a plot (~0.1-1 s): no shrinking, whose hundreds of reruns would take minutes;
# a failure prints the drawn damage in full, which is its reproducer
@settings(PROPERTY, max_examples=fuzz_examples(20), phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(interrupted=st.booleans(), keep=st.integers(0, 40), damages=st.lists(DAMAGE, max_size=3))
def test_damaged_result_directories_resume_and_plot_cleanly(finished, scratch, capsys, interrupted, keep, damages):
    out = scratch / uuid.uuid4().hex
    shutil.copytree(finished, out)
    what = f"a copy of {finished}, interrupted after {keep} state lines: {interrupted}, then {damages}"
    try:
        if interrupted:
            mark_interrupted(out, keep)
        for name, how, fraction, junk in damages:
            damage(out, name, how, fraction, junk)
        result = cli(["run", DUFFING, "-o", str(out), *CHEAP, "--resume"], capsys, what)
        if result is not None:
            assert_clean(*result)
            if result[0] == 0:
                consistent(out)
        result = cli(["plot", str(out), "--point", "0"], capsys, what)
        if result is not None:
            assert_clean(*result)
            if result[0] == 0:
                assert (out / "point_0.png").stat().st_size > 0
    finally:
        restore_modes(out)
        shutil.rmtree(out)


# ------------------------------------------------------------------ the escapes found, one by one (each a traceback
# before it was fixed; an escape found later gets an entry in KNOWN_ESCAPES and an xfail(strict=True) test here)
@pytest.fixture
def copy(finished, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(finished, out)
    return out


@pytest.mark.parametrize("text", [
    pytest.param("model: {builtin: duffing}\nanalysis: {type: frequency_response, range: [0.5, " + "9" * 5000 + "]}\n",
                 id="5000-digit-integer"),
    pytest.param("model: " + "[" * 1000 + "]" * 1000 + "\n", id="1000-levels"),
])
def test_scene_text_escapes(tmp_path, capsys, text):
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    code, err = run(["check", str(path)], capsys)
    assert code == 2 and err.startswith("contin: error:") and len(err) < 2000


@pytest.mark.parametrize("name", ["branches.csv", "special_points.csv"])
def test_resume_with_a_table_that_is_not_utf8(copy, capsys, name):
    mark_interrupted(copy)
    (copy / name).write_bytes(b"\xe9t\xe9\n")
    code, err = run(["run", DUFFING, "-o", str(copy), *CHEAP, "--resume"], capsys)
    assert code == 2 and name in err


def test_resume_with_special_points_of_other_columns(copy, capsys):
    # (branches.csv is cut to its valid rows and rewritten on resume; special_points.csv is appended to)
    mark_interrupted(copy)
    (copy / "special_points.csv").write_text("[1, 2]\n")
    code, err = run(["run", DUFFING, "-o", str(copy), *CHEAP, "--resume"], capsys)
    assert code == 2 and "special_points.csv" in err


@pytest.mark.parametrize("name,content", [
    pytest.param("summary.json", b"[1, 2]\n", id="summary-list"),
    pytest.param("state.jsonl", b"\xe9t\xe9\n", id="state-not-utf8"),
    pytest.param("state.jsonl", b"[1, 2]\n", id="state-list"),
    pytest.param("summary.json", b'{"status": "complete"}\n', id="summary-without-scene"),
    pytest.param("state.jsonl", b'{"type": "point", "row": 0}\n', id="state-record-without-nu"),
])
def test_plot_escapes(copy, capsys, name, content):
    (copy / name).write_bytes(content)
    code, err = run(["plot", str(copy), "--point", "0"], capsys)
    assert code == 2 and name in err


def test_the_cheap_run_resumes_to_the_same_table(copy, finished, capsys):
    """The property's positive case, checked exactly: a run cut two steps before its end, resumed, has the
    rows of the run in one go."""
    mark_interrupted(copy)
    code, err = run(["run", DUFFING, "-o", str(copy), *CHEAP, "--resume"], capsys)
    assert code == 0, err
    consistent(copy)
    ends = []
    for out in (copy, finished):
        with open(out / "branches.csv", newline="") as fh:
            last = list(csv.DictReader(fh))[-1]
        ends.append((float(last["w"]), float(last["amp_x"])))
    assert ends[0] == pytest.approx(ends[1], rel=1e-8)
