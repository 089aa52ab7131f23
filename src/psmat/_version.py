"""The package version, written only here: the wheel's metadata reads it (pyproject.toml,
``[tool.scikit-build.metadata.version]``) and :data:`psmat.__version__` imports it."""

__version__ = "0.1.0"
