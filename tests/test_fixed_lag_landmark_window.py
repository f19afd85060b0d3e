"""A stream's landmarks in a fixed-lag window: held exactly while last seen within the lag (docs/bayes_tree.md).

The rule, as the docs give it: each update stamps the landmarks its factors name with the time of its newest state,
so a landmark is forgotten once the newest state is more than the lag past the last update that read it, and read
again it enters anew. Recorded here from what each update is given (its states' times and its factors' landmarks),
not from the smoother's timestamps: after every step of a synthetic run whose ten landmarks are seen again and
again, the window holds exactly the landmarks whose last sighting is within the lag of the newest state.
tests/test_fixed_lag_stream.py checks that they leave and come back; this checks when.
"""

from __future__ import annotations

from steam_ref.datasets import generate_synthetic
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings


def test_the_window_holds_the_landmarks_seen_within_the_lag(monkeypatch):
    setup, lag = PaperSetup.synthetic(), 4.0
    readings = Readings.from_dataset(generate_synthetic(n_steps=150, n_landmarks=10, seed=2), setup)
    stream = StreamingEstimator(readings, setup, StreamOptions(lag=lag))
    smoother = stream.solver.inner
    last_seen: dict = {}  # landmark → the time of the newest state of the last update whose factors name it
    update = smoother.update

    def recorded(factors, values=None, **options):
        times = [float(readings.times[k.index]) for k in values or {} if k.symbol == "x"]
        when = max(times, default=smoother.newest)
        last_seen.update((k, when) for f in factors for k in f.keys if k.symbol == "l")
        return update(factors, values, **options)

    monkeypatch.setattr(smoother, "update", recorded)
    left = 0
    while not stream.done:
        stream.step()
        held = {k for k in smoother.estimate() if k.symbol == "l"}
        assert held == {k for k, t in last_seen.items() if t >= smoother.newest - lag}, f"at t = {smoother.newest}"
        left += len(last_seen) - len(held)
    assert left > 0 and smoother.n_marginalized > 0
