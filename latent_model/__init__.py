"""The learned surrogate of the cord: a GAN that decodes latents to shapes and an Encoder.

Public API::

    from latent_model import ShapeModel
    model = ShapeModel.load_pretrained()
    z, err, ok = model.invert(shapes)      # (B, n, 2) metres -> latents, errors, represented
    shapes = model.decode(z)               # (B, n, 2) metres

    from latent_model import TransitionModel
    tm = TransitionModel.load_or_pretrained()
    nxt = tm.predict(shapes, "head", d)     # shape at rest after one move of the held end(s)

Training (``train``), additional training (``finetune``) and the quality metrics
(``latent_model.metrics``) are documented in their modules. ``torch`` is required.
"""

from latent_model.config import ModelConfig, TrainConfig
from latent_model.finetune import FinetuneConfig, finetune
from latent_model.shape_model import ShapeModel
from latent_model.training import train
from latent_model.transition_model import TransitionModel, TransitionModelConfig

__all__ = ["FinetuneConfig", "ModelConfig", "ShapeModel", "TrainConfig", "TransitionModel",
           "TransitionModelConfig", "finetune", "train"]
