"""A package with a broken firenav plugin."""
