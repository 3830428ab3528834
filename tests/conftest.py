import os
from pathlib import Path

# The suite steps in CasADi's virtual machine unless a test asks for compiled C (jit=True):
# compiling every scene and step of the suite would cost minutes. simulate() itself compiles
# by default (tests/test_bad_input.py checks the default).
os.environ.setdefault("RRR4_JIT", "0")

import pytest  # noqa: E402
import yaml  # noqa: E402

from rrr4 import load_scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def one_line(e: Exception, *words):
    """`e`'s message is one line holding every one of `words`."""
    msg = str(e)
    assert "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)
PAPER = ROOT / "problems" / "paper_circle.yaml"


@pytest.fixture(scope="session")
def paper_scene():
    return load_scene(PAPER)


@pytest.fixture
def paper_data():
    """The reference scene as a fresh, mutable mapping."""
    return yaml.safe_load(PAPER.read_text())
