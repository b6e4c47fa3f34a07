from ._containment import ellipsoid_contains as ellipsoid_contains
from ._cover import (
    connected_to_center as connected_to_center,
    gram_cover as gram_cover,
    prove_cover as prove_cover,
)
from ._exact import (
    exact_equilibrium as exact_equilibrium,
    exact_positive_definite as exact_positive_definite,
)
from ._interval import (
    INTERVAL as INTERVAL,
    LIBM_ULPS as LIBM_ULPS,
    Interval as Interval,
    box_offsets as box_offsets,
    iabs as iabs,
    iclip as iclip,
    imaximum as imaximum,
    iminimum as iminimum,
    interval_affine as interval_affine,
    round_down as round_down,
    round_up as round_up,
)
from ._jet import Jet as Jet, jabs as jabs, nonsmooth as nonsmooth
from ._jet_net import JET as JET, network_jet as network_jet
from ._local import (
    hessian_negative_definite as hessian_negative_definite,
    local_box as local_box,
    local_box_proof as local_box_proof,
)
from ._recast import polynomial_field as polynomial_field
from ._reductions import ParameterBox as ParameterBox
from ._relax import crown as crown, variables as variables
from ._reverify import reverify as reverify
from ._sector import (
    certified_sector as certified_sector,
    degrees_lower as degrees_lower,
    quadratic_form as quadratic_form,
)
from ._sublevel_containment import sublevel_contains as sublevel_contains
from ._validate import (
    QuadraticForm as QuadraticForm,
    evaluate_boxes as evaluate_boxes,
    validate_level as validate_level,
)
from ._validation import Validation as Validation
from ._whiten import (
    Whitened as Whitened,
    affine_components as affine_components,
    whitened_system as whitened_system,
    whitening_for as whitening_for,
)
from ._witness import recheck_witness as recheck_witness
