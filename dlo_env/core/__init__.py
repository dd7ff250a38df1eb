"""The utilities every package uses, at the bottom of the project: they import none of its
packages (``dlo_env``'s environments, ``latent_model``, ``planners``, ``dlo_bench``,
``dlo_cli``), and all of them import these.

- :mod:`dlo_env.core.atomic`: atomic file writes (``atomic_path``, ``write_text_atomic``) and
  file digests.
- :mod:`dlo_env.core.checks`: range checks of configuration fields.
- :mod:`dlo_env.core.progress`: progress bars (tqdm on a terminal, else a line per tenth).
- :mod:`dlo_env.core.process_backend`: independent calls in worker processes of this machine.
- :mod:`dlo_env.core.ray_backend`: independent calls as Ray tasks, on one machine or a cluster.
- :mod:`dlo_env.core.deprecation`: old names kept working as deprecated aliases.
"""
