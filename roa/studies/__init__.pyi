from ._experiment import (
    MAX_SEED as MAX_SEED,
    VERDICTS as VERDICTS,
    accepts as accepts,
    check_int as check_int,
    check_number as check_number,
    check_numbers as check_numbers,
    check_params as check_params,
    experiments_dir as experiments_dir,
    list_experiments as list_experiments,
    load_config as load_config,
    output_hashes as output_hashes,
    run_experiment as run_experiment,
    verify_outputs as verify_outputs,
)
from ._recompute import recompute as recompute
from ._reference import Entry as Entry
from ._registry import (
    GROUP as GROUP,
    Study as Study,
    get as get,
    registered as registered,
    runner_allowed as runner_allowed,
    systems as systems,
)
