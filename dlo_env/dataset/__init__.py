"""Dataset production: cord-like shapes and one-move transitions, their files and measures.

- :mod:`dlo_env.dataset.collect`: parallel, resumable collection of shapes (``dlo collect``).
- :mod:`dlo_env.dataset.shape_file`: the shape ``.npz`` format, loading and splits.
- :mod:`dlo_env.dataset.diversity`: coverage and diversity measures of a shape set.
"""
