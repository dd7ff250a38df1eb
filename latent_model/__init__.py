"""The learned models of the cord: the shape model, the transition model, and the learned cord
they make as a differentiable step function and as Gymnasium environments.

Public API::

    from latent_model import ShapeModel
    model = ShapeModel.load_pretrained()
    z, err, ok = model.invert(shapes)      # (B, n, 2) metres -> latents, errors, represented
    shapes = model.decode(z)               # (B, n, 2) metres

    from latent_model import TransitionModel
    tm = TransitionModel.load_or_pretrained()
    nxt = tm.predict(shapes, "head", d)     # shape at rest after one move of the held end(s)

Modules:

- The shape model (``ShapeModel``, in ``shape_model``): a GAN whose generator decodes latents
  to shapes, and an Encoder that inverts it. ``config`` holds its settings, ``networks`` the
  networks, ``pose`` and ``normalisation`` the frames and scales they work in, ``losses`` and
  ``training`` its training (``train``) on shape files read by ``dataset``, ``finetune`` the
  additional training (``finetune``), ``inversion`` the refinement of latents, ``metrics`` and
  ``evaluation`` its quality.
- The transition model (``TransitionModel``, in ``transition_model``): the shape at rest after
  one straight move of the held end(s). ``move_frame`` is the frame it works in,
  ``chain_network`` its chain-local design, ``inextensible`` the projection onto rest-length
  segments, ``transition_training`` and ``transition_metrics`` its training and measurement.
- The learned cord: ``cord_dynamics`` is the transition model as a batched, differentiable
  step function in torch, ``surrogate_env`` the Gymnasium environments that step it.
- ``checkpoint`` reads and writes the models' files.

``torch`` is required.
"""
from latent_model.config import ModelConfig, TrainConfig
from latent_model.finetune import FinetuneConfig, finetune
from latent_model.shape_model import ShapeModel
from latent_model.training import train
from latent_model.transition_model import TransitionModel, TransitionModelConfig

__all__ = ["FinetuneConfig", "ModelConfig", "ShapeModel", "TrainConfig", "TransitionModel",
           "TransitionModelConfig", "finetune", "train"]
