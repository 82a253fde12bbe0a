"""Writing hand-made plan documents for the building tests."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def write_plan(folder: Path, doc: Any, name: str = "plan.geojson") -> Path:
    """``doc`` written as JSON to ``folder / name``; the path."""
    path = folder / name
    path.write_text(json.dumps(doc))
    return path
