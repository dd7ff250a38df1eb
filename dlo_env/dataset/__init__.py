"""Dataset production: cord-like shapes and one-move transitions, their files and measures.

- ``collect``: parallel, resumable collection of shapes (``dlo collect shapes``).
- ``transitions``: one-move transitions and their collection (``dlo collect transitions``).
- ``chunks``: the chunked, resumable, parallel mechanism both collections share.
- ``remote_chunks``: a chunk made as a Ray task on any node, returned as bytes.
- ``ray_backend``: the old location of ``dlo_env.core.ray_backend.RayBackend`` (deprecated).
- ``npz_file``: the one ``.npz`` layout of the datasets (typed arrays and JSON metadata).
- ``shape_file``: the shape ``.npz`` format, loading and splits.
- ``diversity``: coverage and diversity measures of a shape set.
- ``minari_export``: Minari datasets of the suites' oracle demonstrations and of transitions.
"""
