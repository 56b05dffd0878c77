"""The app's estimator on a thread of its own, off the plant thread's critical path.

    estimator = EstimatorThread(make_estimator("ukf", task))   # an Estimator: the closed loop calls it as one
    closed_loop = ClosedLoop(controller, system, estimator=estimator)

The plant thread only reads, steps and serves: each `update` hands the raw reading (and the action
served since the one before) to the filter's thread and returns at once with the newest estimate,
predicted to the plant's now on the planning model under the actions served since (its mean only:
one `mj_step` per plant step, against the UKF's 2n sigma points). The filter's thread fuses the
newest reading waiting, with every served action in order; readings that a newer one overtook while
the filter was busy are passed over (a sensor's value held in the newer reading is fused from
there). So a filter slower than the plant's step makes the estimate lag (`lag`), not the plant:
judo's own simulator keeps real time. A filter more than CATCH_UP_LAG behind starts over from the
prediction at the plant's now and the newest reading (`catch_ups`), so its lag stays within
CATCH_UP_LAG and one update.

The app's plant runs through it (`build_session(..., estimator_thread=True)`, beside the plant
runner of this package); evaluate, tune and collect call their estimator on the stepping thread, so
their episodes stay deterministic.

A reset (`judo.loop.estimation.Estimation.restart`, after the plant's reset or a switch) restarts
the filter from the next reading on the plant thread, waiting for an update in flight: readings of
before it are dropped. A config edit (`config = ...` from the GUI's thread) is handed to the filter
before its next update. An exception on the filter's thread is raised from the plant thread's next
`update` as an EstimatorThreadError (the app reports a failed read_state, as for a filter on the
plant thread); the filter goes on with the next reading. `close()` ends the (daemon) thread within
`timeout`.
"""  # noqa: E501

import dataclasses
import math
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from judo.core.errors import JudoError
from judo.core.estimator import ControlHistory, Estimator, EstimatorConfig, estimate_of
from judo.core.reading import SystemState
from judo.loop.timing import LatencyPredictor

JOIN_TIMEOUT = 0.2
"""Seconds `close` waits for the filter's thread to finish its update in flight."""
CATCH_UP_LAG = 0.5
"""Seconds of plant time the filter may fall behind before it starts over from the prediction at the
plant's now."""


class EstimatorThreadError(JudoError):
    """The estimator raised on its own thread; the message names the estimator and its error."""


@dataclass(frozen=True)
class _Handed:
    """One reading handed to the filter's thread: its reset `epoch`, the plant time to estimate at,
    and the
    (time, (nu,) action) served since the reading before (None if none)."""

    epoch: int
    reading: SystemState
    time: float
    control: tuple[float, np.ndarray] | None


class EstimatorThread(Estimator):
    """Runs `estimator` on a daemon thread of its own; see the module docstring.

    Args:
        estimator: the filter; after this, only the filter's thread (and a reset) call it, under
            `_lock`.

    Attributes:
        estimator: the filter that fuses the readings.
        lag: seconds of plant time the newest estimate was behind the plant's now at the latest
            `update`.
        fused: readings fused so far (on the thread, and the first after each reset on the plant
            thread).
        passed_over: readings a newer one overtook before the filter got to them.
        failures: updates that raised on the filter's thread.
        catch_ups: times the filter fell CATCH_UP_LAG behind and started over from the prediction at
            the plant's now.
    """

    # not Estimator.__init__: `config` is the handed-over one
    def __init__(self, estimator: Estimator) -> None:
        self.task, self.estimator = estimator.task, estimator
        # guards the hand-over: queue, newest estimate, config, error
        self._mutex = threading.Condition()
        self._lock = threading.Lock()  # held while the filter runs (its thread, or a reset)
        self._config: EstimatorConfig = estimator.config
        self._queue: deque[_Handed] = deque()
        self._epoch = self._version = 0
        self._estimate: SystemState | None = None  # the newest fused estimate, version `_version`
        self._error: Exception | None = None
        self._closing = False
        self._thread: threading.Thread | None = None
        self._controls = ControlHistory(self.task.nu)  # the filter's copy of the served actions
        self._handed_control = -math.inf  # time of the newest action handed over
        self._bridge: SystemState | None = None  # the estimate predicted to the plant's latest now
        self._bridged_version = -1
        self._predictor = LatencyPredictor(self.task)
        # the next update is the first since a reset: fused on the calling thread
        self._first = True
        self.lag = 0.0
        self.fused = self.passed_over = self.failures = self.catch_ups = 0

    @property
    def config(self) -> Any:
        """The filter's config; an edit is handed to the filter before its next update."""
        with self._mutex:
            return self._config

    @config.setter
    def config(self, config: EstimatorConfig) -> None:
        with self._mutex:
            self._config = config

    def reset(self, reading: SystemState) -> None:
        """Restart the filter from `reading`, waiting for an update in flight; readings handed
        before are dropped."""
        with self._lock:
            with self._mutex:
                self._epoch += 1
                self._queue.clear()
                self._estimate, self._error, self._bridge = None, None, None
            self._controls = ControlHistory(self.task.nu)
            self._handed_control = -math.inf
            self._take_config()
            self.estimator.reset(reading)
        self._first = True

    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        """Hand `reading` to the filter's thread and return the newest estimate predicted to plant
        `time` (the first after a reset is fused here). Raises EstimatorThreadError for an update
        that failed on the thread since the last call."""
        latest = controls.latest()
        control = latest if latest is not None and latest[0] > self._handed_control else None
        if control is not None:
            self._handed_control = control[0]
        if self._first:
            with self._lock:
                if control is not None:
                    self._controls.append(*control)
                self._take_config()
                estimate = self.estimator.update(reading, time, self._controls)
            self._first = False
            with self._mutex:
                self._estimate, self._version, self.fused = (
                    estimate,
                    self._version + 1,
                    self.fused + 1,
                )
        else:
            with self._mutex:
                self._queue.append(_Handed(self._epoch, reading, time, control))
                self._mutex.notify()
                error, self._error = self._error, None
            self._start()
            if error is not None:
                name = type(self.estimator).__name__
                raise EstimatorThreadError(
                    f"{name} failed on its thread: {type(error).__name__}: {error}"
                ) from error
        return self._bridged(reading, time, controls)

    def covariance(self) -> np.ndarray | None:
        """The filter's (2 nv + na, 2 nv + na) covariance at its newest estimate (waits for an
        update in flight)."""
        with self._lock:
            return self.estimator.covariance()

    def close(self, timeout: float = JOIN_TIMEOUT) -> None:
        """End the filter's thread, waiting at most `timeout` s for its update in flight."""
        with self._mutex:
            self._closing = True
            self._mutex.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    def _bridged(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        """The newest estimate predicted to plant `time` under the served `controls`: from the
        estimate when it is new, else on from the last prediction (one step per plant step)."""
        with self._mutex:
            estimate, version = self._estimate, self._version
        assert estimate is not None  # fused on the calling thread after every reset
        base = (
            estimate if version != self._bridged_version or self._bridge is None else self._bridge
        )
        self._bridged_version, self.lag = version, max(0.0, time - estimate.time)
        ahead = self._predictor.predict_reading(
            base, time - base.time, lambda now, _state: controls.at(now)
        )
        self._bridge = ahead
        return estimate_of(reading, np.asarray(ahead.state), ahead.time)

    def _catch_up_if_behind(self, newest: _Handed) -> None:
        """Start the filter over from the plant thread's prediction (with `newest`'s sensors) when
        its estimate is more than CATCH_UP_LAG behind `newest`: a filter slower than the plant would
        fall further behind at every update, and the planner would plan from an ever longer
        prediction that no reading corrects."""
        estimate, bridge = self._estimate, self._bridge
        if estimate is None or bridge is None or newest.time - estimate.time <= CATCH_UP_LAG:
            return
        self.estimator.reset(
            dataclasses.replace(newest.reading, state=bridge.state, time=bridge.time)
        )
        self.catch_ups += 1

    def _take_config(self) -> None:
        """Give the filter the config edited last (under `_lock`)."""
        with self._mutex:
            config = self._config
        if self.estimator.config is not config:
            self.estimator.config = config

    def _start(self) -> None:
        if self._thread is None and not self._closing:
            self._thread = threading.Thread(target=self._run, name="judo-estimator", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        """The filter's thread: fuse the newest reading handed over, with every action served, until
        `close`."""
        while True:
            with self._mutex:
                while not self._queue and not self._closing:
                    self._mutex.wait()
                if self._closing:
                    return
                handed = list(self._queue)
                self._queue.clear()
            with self._lock:
                handed = [h for h in handed if h.epoch == self._epoch]  # none from before a reset
                if not handed:
                    continue
                for item in handed:
                    if item.control is not None:
                        self._controls.append(*item.control)
                newest = handed[-1]
                self._take_config()
                try:
                    self._catch_up_if_behind(newest)
                    estimate = self.estimator.update(newest.reading, newest.time, self._controls)
                except Exception as err:  # raised from the plant thread's next update
                    with self._mutex:
                        self._error = err
                        self.failures += 1
                    continue
                with self._mutex:
                    self._estimate, self._version = estimate, self._version + 1
                    self.fused, self.passed_over = (
                        self.fused + 1,
                        self.passed_over + len(handed) - 1,
                    )
