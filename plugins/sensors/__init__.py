"""Built-in sensors (registered under the firenav.plugins entry-point group in pyproject.toml)."""
