from ._basin import BasinResult as BasinResult, basin as basin
from ._certified_set import terminal_from_certificate as terminal_from_certificate
from ._certified_share import clopper_pearson as clopper_pearson, share_line as share_line
from ._chunks import ChunkRejectedWarning as ChunkRejectedWarning
from ._engine import (
    SCHEDULER_TIMEOUT as SCHEDULER_TIMEOUT,
    BasinRun as BasinRun,
    run_basin as run_basin,
    wilson_interval as wilson_interval,
)
from ._robust_basin import (
    RobustBasinResult as RobustBasinResult,
    parameter_samples as parameter_samples,
)
from ._sampling import (
    MAX_SAMPLES as MAX_SAMPLES,
    box_sample as box_sample,
    grid_slice as grid_slice,
    region_sample as region_sample,
)
