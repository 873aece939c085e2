"""docs/suites.md documents every key a suite file may hold, and its TOML examples load.

A study kind that gains a key fails here until the key has a row in that kind's section;
an example that the loader would refuse fails too."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from harness.run import load_suite
from harness.run.studies import STUDIES
from harness.run.suite import _SUITE_KEYS

DOC = Path(__file__).resolve().parent.parent / "docs" / "suites.md"


def _sections(text: str) -> dict[str, str]:
    """The text under each level-2 heading, by heading."""
    parts = re.split(r"^## (.+)$", text, flags=re.M)
    return {head.strip(): body for head, body in zip(parts[1::2], parts[2::2], strict=True)}


def _table_keys(body: str) -> set[str]:
    """The keys of a section's table: the first cell of each row, in backticks."""
    return set(re.findall(r"^\| `([A-Za-z_]+)` \|", body, flags=re.M))


SECTIONS = _sections(DOC.read_text())


@pytest.mark.parametrize("kind", sorted(STUDIES))
def test_every_key_of_every_study_kind_is_documented(kind):
    head = f'kind = "{kind}"'
    assert head in SECTIONS, f"docs/suites.md has no section `## {head}`"
    documented = _table_keys(SECTIONS[head])
    keys = set(STUDIES[kind].keys)
    assert not keys - documented, f"{kind}: keys not documented: {sorted(keys - documented)}"
    assert not documented - keys, (
        f"{kind}: documented keys it does not take: {sorted(documented - keys)}"
    )


def test_suite_table_keys_are_documented():
    documented = _table_keys(SECTIONS["`[suite]`"])
    assert documented == set(_SUITE_KEYS)


def test_no_section_for_a_kind_that_does_not_exist():
    kinds = {m.group(1) for h in SECTIONS if (m := re.fullmatch(r'kind = "(\w+)"', h))}
    assert kinds == set(STUDIES)


def _toml_blocks(text: str) -> list[str]:
    return re.findall(r"^```toml\n(.*?)^```$", text, flags=re.M | re.S)


def test_the_doc_has_examples():
    blocks = _toml_blocks(DOC.read_text())
    assert len(blocks) >= 2
    assert any("[[study]]" in b and b.count("[[study]]") >= 2 for b in blocks)


@pytest.mark.parametrize("index", range(len(_toml_blocks(DOC.read_text()))))
def test_toml_examples_load(index, tmp_path):
    """Every TOML block of the doc is a suite the loader accepts (no run: loading checks
    every key, compiles the scenes and counts the cases)."""
    block = _toml_blocks(DOC.read_text())[index]
    f = tmp_path / "example.toml"
    f.write_text(block)
    suite = load_suite(f)
    assert suite.studies


def test_sweep_example_expands_as_the_doc_says(tmp_path):
    """The doc says the sweep expands to 28 cases: keep it true."""
    from harness.run import expand

    block = next(b for b in _toml_blocks(DOC.read_text()) if 'name = "sweep"' in b)
    f = tmp_path / "sweep.toml"
    f.write_text(block)
    assert len(expand(load_suite(f))) == 28
    assert "It expands to 28 cases" in DOC.read_text()


def _allowed(kind: str, key: str) -> str:
    """The `allowed` cell of `key`'s row in `kind`'s section."""
    row = next(r for r in SECTIONS[f'kind = "{kind}"'].splitlines() if r.startswith(f"| `{key}` |"))
    return row.split(" | ")[3]


def test_documented_names_are_the_valid_ones():
    """The lists of valid names in the doc are the registries the parsers check against."""
    import motions
    import scenes
    from harness.certification import ENGINE_BOUNDS
    from harness.corpus import FAMILIES
    from harness.corpus.methods import METHODS
    from harness.workloads import EXTERNAL

    def listed(cell: str) -> list[str]:
        return re.findall(r"`([a-z0-9_-]+)`", cell)

    assert listed(_allowed("certify", "scenes")) == list(scenes.SCENES)
    assert listed(_allowed("certify", "schemes")) == list(motions.SCHEMES)
    for kind in ("certify", "workload"):
        assert listed(_allowed(kind, "bounds")) == list(ENGINE_BOUNDS)
    assert listed(_allowed("workload", "external")) == list(EXTERNAL)
    assert listed(_allowed("corpus", "families")) == list(FAMILIES)
    assert listed(_allowed("corpus", "methods")) == list(METHODS)
