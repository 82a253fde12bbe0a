"""Built-in firenav plugins (installed as ``firenav_plugins``)."""
