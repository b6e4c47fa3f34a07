"""The IPC paper study: reproduction of the seed paper's claims with the ``roa`` library.

Everything specific to the paper lives here, beside the library: the symbolic derivation and its
errata, Figures 1-2, the analytic bound, Khalil's search for the paper's V, basin studies, the
certify runs, the claims table (``paper_repro.md``) and the reference values of ``roa check``,
and the system itself (model, controller, coordinates, closed loops, the paper's V):
:mod:`ipc_paper.system`. The study declares its systems to the library (``STUDY.systems``), so
``load_system("ipc")`` and ``--system ipc-flat`` work like the library's built-ins.

Each experiment config in ``experiments/`` names its runner as ``ipc_paper.MODULE:FUNCTION``.
"""

from pathlib import Path

from roa.studies import Study

STUDY = Study(
    name="ipc",
    package="ipc_paper",
    experiments=Path(__file__).resolve().parent / "experiments",
    reference="ipc_paper.reference:REGISTRY",
    report="ipc_paper.report:render_report",
    report_name="paper_repro.md",
    commands=("ipc_paper.commands.bound", "ipc_paper.commands.simulate"),
    systems={
        "ipc": "ipc_paper.system:closed_loop",
        "ipc-flat": "ipc_paper.system:transformed",
        "ipc-flat-uncertain": "ipc_paper.system:transformed_uncertain",
    },
)
