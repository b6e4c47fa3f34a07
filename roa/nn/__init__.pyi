from ._mlp import MLP as MLP
from ._ops import ACTIVATION_NAMES as ACTIVATION_NAMES, Activation as Activation, Affine as Affine
