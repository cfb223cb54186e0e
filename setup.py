# Installs the Python module src/rrr_graphslam through catkin (catkin_python_setup).
from distutils.core import setup

from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["rrr_graphslam"], package_dir={"": "src"}))
