import os
import sys

# The module from the source tree, whether or not the workspace is sourced.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "src"))

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data")
