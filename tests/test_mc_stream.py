"""The Monte Carlo's streaming: draws a chunk at a time, bounded work in flight, rows in order.

The reference draws are :func:`draw_samples` (everything at once, one
generator); the reference table is :func:`write_columns` over the whole
result. Nothing here depends on the machine or on time.
"""

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.export.files import write_columns
from corr_cad.tolerance.mc_chunks import CHUNK_BYTES, CHUNK_MAX, IN_FLIGHT_PER_WORKER
from corr_cad.tolerance.montecarlo import (
    Distribution,
    DrawStream,
    SerialExecutor,
    chunk_size,
    draw_samples,
    monte_carlo,
)

M0 = 1.1e5
ALL = {
    "cam_radius": Distribution("normal", 0.002),
    "eccentricity": Distribution("uniform", 0.003),
    "cam_phase": Distribution("normal", 0.01),
    "roller_radius": Distribution("uniform", 0.001),
    "slot_angle": Distribution("normal", 0.005),
}


@pytest.mark.parametrize(
    "kinds",
    [tuple(ALL), ("roller_radius",), ("cam_radius",), ("eccentricity", "slot_angle")],
)
def test_draw_stream_gives_the_draws_of_draw_samples_bit_for_bit(kinds):
    tol = {k: ALL[k] for k in kinds}
    ref = draw_samples(tol, 37, 9, 26)
    stream = DrawStream(tol, 37, 9, 26)
    parts = [stream.take(k) for k in (1, 10, 0, 26)]  # uneven chunks, one empty
    assert stream.kinds == list(ref)
    for kind, whole in ref.items():
        assert np.array_equal(np.concatenate([p[kind] for p in parts]), whole), kind


class _Counting(SerialExecutor):
    """A serial executor that records how many submitted tasks were not yet collected."""

    _max_workers = 3

    def __init__(self):
        self.open = self.most = 0

    def submit(self, fn, *args):
        self.open += 1
        self.most = max(self.most, self.open)
        lazy = super().submit(fn, *args)
        outer = self

        class _Tracked:
            def result(self):
                outer.open -= 1
                return lazy.result()

        return _Tracked()


def test_work_in_flight_is_bounded_and_rows_arrive_in_order_whatever_the_chunk():
    tol = {"roller_radius": ALL["roller_radius"], "cam_phase": ALL["cam_phase"]}
    ref = monte_carlo(GearDesign(), M0, tol, 40, 3, 12, kernel=False, chunk=40)
    ex, seen = _Counting(), []
    got = monte_carlo(
        GearDesign(),
        M0,
        tol,
        40,
        3,
        12,
        kernel=False,
        chunk=3,
        executor=ex,
        sink=lambda lo, mags, metrics: seen.append((lo, mags, metrics)),
    )
    assert ex.most == 3 * IN_FLIGHT_PER_WORKER  # 14 chunks, never more than the window open
    assert [lo for lo, _, _ in seen] == list(range(0, 40, 3))
    for k, v in ref.metrics.items():
        assert np.array_equal(got.metrics[k], v), k
        assert np.array_equal(np.concatenate([m[k] for _, _, m in seen]), v), k
    for k, v in ref.magnitudes.items():
        assert np.array_equal(got.magnitudes[k], v), k
        assert np.array_equal(np.concatenate([g[k] for _, g, _ in seen]), v), k


def test_chunk_is_bounded_whatever_the_sample_count():
    per = 40_000.0  # bytes of a sample's work: CHUNK_BYTES binds before CHUNK_MAX
    cap = int(CHUNK_BYTES // per)
    assert cap < CHUNK_MAX
    assert chunk_size(10**4, 16, 3000.0) == 157  # four chunks a worker: ceil(1e4 / 64)
    assert chunk_size(10**6, 2, per) == cap == chunk_size(10**8, 2, per)
    assert chunk_size(10**6, 2, 100.0) == CHUNK_MAX == chunk_size(10**8, 64, 100.0)
    assert chunk_size(10, 2, per) == 50  # a task's fixed cost is worth 50 samples at least
    # Half a second of estimated work at most (a stalled worker is seen within seconds).
    assert chunk_size(10**6, 2, 100.0, 1e-3) == 500
    assert chunk_size(10**6, 2, 100.0, 1.0) == 50


def test_streamed_montecarlo_csv_has_the_bytes_of_the_whole_table(tmp_path):
    """The stage writes montecarlo.csv chunk by chunk; the bytes are those of one write."""
    from corr_cad.export.files import atomic_writer
    from corr_cad.run.stages.stages_tolerance import _RowStream

    tol = {"roller_radius": ALL["roller_radius"], "cam_radius": ALL["cam_radius"]}
    with atomic_writer(tmp_path / "streamed.csv") as f:
        res = monte_carlo(GearDesign(), M0, tol, 23, 5, 12, chunk=4, sink=_RowStream(f))
    names, kinds = list(res.metrics), list(res.magnitudes)
    header = ["sample"] + [f"{k}_magnitude" for k in kinds] + names
    cols = [np.arange(23)] + [res.magnitudes[k] for k in kinds] + [res.metrics[m] for m in names]
    write_columns(tmp_path / "whole.csv", header, cols, ["%d"] + ["%.9g"] * (len(cols) - 1))
    assert (tmp_path / "streamed.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
