"""Imports something that is not installed, as a broken plugin would."""
import firenav_nonexistent_dependency  # noqa: F401
