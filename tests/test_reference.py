"""The reference pages are the code's own: every scene key the reader knows is documented,
every documented key exists, and the generated pages in docs/ are current."""

from __future__ import annotations

from pathlib import Path

import pytest

from rrr4.scene.reference import descriptions, reference_markdown, scene_keys

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def keys():
    return scene_keys()


def test_every_scene_key_is_documented(keys):
    docs = descriptions()
    assert sorted(set(keys) - set(docs)) == [], "undocumented scene keys: add them to rrr4/scene/reference.yaml"
    assert sorted(set(docs) - set(keys)) == [], "documented keys the reader does not read"
    assert all(d.get("text") for d in docs.values())


def test_recorded_rules_are_the_readers(keys):
    # a choice lists the vocabulary; a bounded number its interval
    from rrr4.scene.vocabulary import CONTACT_LAWS, INTEGRATORS
    assert keys["effects.contact.law"]["rule"].split(", ") == list(CONTACT_LAWS)
    assert keys["integrator.method"]["rule"].split(", ") == list(INTEGRATORS)
    assert keys["effects.contact.restitution"]["rule"] == "(0, 1]"
    assert 0.9 in keys["effects.contact.restitution"]["defaults"]


def test_scene_reference_page_is_current(keys):
    page = (ROOT / "docs" / "scene-reference.md").read_text(encoding="utf-8")
    assert page == reference_markdown(keys), (
        "docs/scene-reference.md is stale: python -m rrr4.scene.reference > docs/scene-reference.md")


def test_cli_and_api_pages_are_current():
    import subprocess
    import sys

    r = subprocess.run([sys.executable, str(ROOT / "docs" / "make_reference.py"), "--check"],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr


def test_every_relative_link_in_the_docs_resolves():
    import re

    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text(encoding="utf-8")):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not (page.parent / target).exists():
                broken.append(f"{page.relative_to(ROOT)} -> {target}")
    assert broken == []
