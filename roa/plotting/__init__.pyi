from ._basin import (
    KIND_STYLES as KIND_STYLES,
    KIND_WORDS as KIND_WORDS,
    LINE_STYLE as LINE_STYLE,
    region_label as region_label,
    save_figure as save_figure,
    slice_containment as slice_containment,
    slice_figure as slice_figure,
)
from ._trajectories import (
    plot_run as plot_run,
    plot_runs as plot_runs,
    state_labels as state_labels,
)
