"""One category for every warning contin issues: contin.ContinWarning."""

import ast
import warnings
from pathlib import Path

import pytest

import contin
from contin.util.warning import ContinWarning

PACKAGE = Path(contin.__file__).resolve().parent


def test_the_category_is_exported_and_filterable():
    assert contin.ContinWarning is ContinWarning and issubclass(ContinWarning, UserWarning)
    assert "ContinWarning" in contin.__all__
    with warnings.catch_warnings():
        warnings.filterwarnings("error", category=contin.ContinWarning)
        with pytest.raises(ContinWarning, match="a caveat"):
            warnings.warn("a caveat", ContinWarning)
        with pytest.warns(RuntimeWarning):
            warnings.warn("another library's", RuntimeWarning)  # not contin's: not escalated
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", category=contin.ContinWarning)
        warnings.warn("a caveat", ContinWarning)
    assert record == []


def _warn_calls():
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text()
        if "warn(" not in text:  # parsed only where a call may be: parsing all would be slow
            continue
        for node in ast.walk(ast.parse(text, str(path))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "warn" \
                    and isinstance(node.func.value, ast.Name) and node.func.value.id == "warnings":
                category = node.args[1] if len(node.args) > 1 else next(
                    (k.value for k in node.keywords if k.arg == "category"), None)
                yield f"{path.relative_to(PACKAGE)}:{node.lineno}", category


def test_every_warning_contin_issues_is_a_contin_warning():
    # before: RuntimeWarning everywhere (the disagreement warning, the cache directory, the saltation)
    calls = list(_warn_calls())
    assert len(calls) >= 4
    other = [where for where, cat in calls if not (isinstance(cat, ast.Name) and cat.id == "ContinWarning")]
    assert not other, f"warnings.warn without category ContinWarning at {other}"
