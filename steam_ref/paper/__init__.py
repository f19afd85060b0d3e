"""The paper's experiments: its set-ups and Algorithm 1 on its data.  [YIB Sec. IV]

Above the algorithm (which knows nothing of data sets or schedules), in the order data flows:

- :mod:`~steam_ref.paper.presets`: :class:`PaperSetup`, every parameter of a run as the authors'
  scripts set it (noise, Qc, the motion prior, Plaza's range correction, the schedule's defaults);
- :mod:`~steam_ref.paper.readings`: a data set's readings in the solver's terms;
- :mod:`~steam_ref.paper.frontend`: Algorithm 1 step 1, readings to factors (one front end for batch
  and stream);
- :mod:`~steam_ref.paper.problem`, :mod:`~steam_ref.paper.converge`: the batch problem and its optimum;
- :mod:`~steam_ref.paper.online_solver`: :class:`OnlineSolver`, what the run loop asks of every solver, and how a
  forgotten past is read; :mod:`~steam_ref.paper.solvers`: PB, PBVR, BTGP and the fixed-lag BTGP;
- :mod:`~steam_ref.paper.options`: :class:`StreamOptions`, what one run chooses on top of its set-up;
- :mod:`~steam_ref.paper.results`, :mod:`~steam_ref.paper.online`: a run's results, and the run loop;
- :mod:`~steam_ref.paper.fidelity`, :mod:`~steam_ref.paper.experiments`: against the authors' saved
  runs; Fig. 3 and 4.
"""

from .online import run_online
from .options import StreamOptions
from .presets import PaperSetup, Schedule
from .readings import Readings
from .results import RunResult

__all__ = ["PaperSetup", "Schedule", "Readings", "StreamOptions", "RunResult", "run_online"]
