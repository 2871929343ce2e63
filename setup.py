"""Package list only (everything else is in pyproject.toml): the repository's urdf/ folder
becomes the data package ``pinclear.urdf``, which a static find cannot express."""
from setuptools import find_packages, setup

setup(packages=find_packages(include=["pinclear", "pinclear.*"]) + ["pinclear.urdf"],
      package_dir={"pinclear.urdf": "urdf"})
