from pathlib import Path

import pytest
import yaml

from rrr4 import load_scene

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "problems" / "paper_circle.yaml"


@pytest.fixture(scope="session")
def paper_scene():
    return load_scene(PAPER)


@pytest.fixture
def paper_data():
    """The reference scene as a fresh, mutable mapping."""
    return yaml.safe_load(PAPER.read_text())
