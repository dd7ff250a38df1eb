"""The ``dlo`` command: the long-running jobs of the project (top of the import graph)."""
