"""Where the repository, the bench's shared tools and the shared data sets are."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATA = REPO.parent / "shared" / "data"
# Test tools the bench shares with the tests (fuzz cases, the scripted user): they are no part of
# the installed package; bench scripts import them as siblings, conftest puts this folder on sys.path.
BENCH = REPO / "bench"
