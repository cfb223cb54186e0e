"""The test environment: the module from this source tree, in-process and for the scripts the
tests run as subprocesses (which, like installed scripts, import it from PYTHONPATH: a sourced
workspace puts it there; the scripts do not edit sys.path themselves)."""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.normpath(os.path.join(HERE, "..", "..", "src"))
SCRIPTS = os.path.normpath(os.path.join(HERE, "..", "..", "scripts"))
DATA = os.path.normpath(os.path.join(HERE, "..", "data"))

# In-process: this tree's module, whether or not a workspace is sourced.
sys.path.insert(0, SRC)
# Subprocesses: after a sourced workspace's entries (its devel package extends itself to the
# source tree and adds the generated messages), so that alone it still finds this tree's module.
os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (os.environ.get("PYTHONPATH"), SRC) if p)
