#!/usr/bin/env python3
"""Write the colour-science reference fixtures that lumifit's Rust tests compare against.

    pip install -r scripts/reference/requirements.txt
    python3 scripts/reference/colour_reference.py

Writes fixtures/*.json: inputs as values, expected outputs, tolerance, and the colour and numpy
versions used. The tests never need Python; rerun this only when a fixture must change.
"""

import os
import sys
import warnings

warnings.filterwarnings("ignore")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import colour  # noqa: E402
import numpy as np  # noqa: E402

import ref_colour_spaces  # noqa: E402
import ref_tristimulus  # noqa: E402

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
FIXTURES = os.path.join(ROOT, "fixtures")


def main():
    os.makedirs(FIXTURES, exist_ok=True)
    meta = {
        "generator": "scripts/reference/colour_reference.py",
        "colour_version": colour.__version__,
        "numpy_version": np.__version__,
    }
    ref_tristimulus.write(FIXTURES, meta)
    ref_colour_spaces.write(FIXTURES)
    print(f"fixtures written with colour {colour.__version__}, numpy {np.__version__}")


if __name__ == "__main__":
    main()
