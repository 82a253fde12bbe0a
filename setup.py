"""Package discovery that maps the ``plugins/`` folder to the ``firenav_plugins`` name.

Everything else lives in pyproject.toml. A generic top-level name such as ``plugins``
must never land in site-packages, so each package found under ``plugins/`` is renamed.
"""
from setuptools import find_packages, setup

framework = find_packages(include=["firenav_framework", "firenav_framework.*"])
plugins = ["firenav_plugins" + name[len("plugins"):]
           for name in find_packages(include=["plugins", "plugins.*"])]

setup(packages=framework + plugins, package_dir={"firenav_plugins": "plugins"})
