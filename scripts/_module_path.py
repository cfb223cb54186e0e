"""Lets the scripts import rrr_graphslam from the source tree when the package is not installed."""
import os
import sys

try:
    import rrr_graphslam  # noqa: F401  (installed or on PYTHONPATH via devel/setup.bash)
except ImportError:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
