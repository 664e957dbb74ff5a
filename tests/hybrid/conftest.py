"""Test configuration of the engine tests: make ``problems`` (this folder) and the repository
(``hybrid``, ``models``) importable however pytest is started."""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

for _path in (str(HERE), str(ROOT)):
    if _path not in sys.path:
        sys.path.insert(0, _path)
