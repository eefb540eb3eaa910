"""Many runs stepped together: `simulate_many`, its queue of prepared runs and its threads.

Each thread steps packs of runs of one timestep (rail_mj.simulation.stepping), the longest
runs waiting first, and refills a pack's places from the queue as its runs end.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

from rail_mj.layout import Layout
from rail_mj.practice import DERAILMENT_LATERAL
from rail_mj.simulation import native
from rail_mj.simulation.run import Request, Run, SimulationError
from rail_mj.simulation.runner import prepare
from rail_mj.simulation.stepping import PACK, Pack, Prepared, Roller, Running, drive, stepping


def simulate_many(
    requests: list[Request],
    threads: int = 1,
    derailment_lateral: float = DERAILMENT_LATERAL,
    finished: Callable[[int, Run | Exception, float], None] | None = None,
    stop: threading.Event | None = None,
    keep: bool = True,
) -> list[Run | Exception | None]:
    """Many runs stepped together, each result exactly the Run that `simulate` gives for its
    request, bit for bit, or the exception it raises (ValueError, SimulationError).

    `threads` threads step a MuJoCo model each, holding up to PACK runs of one timestep
    (each vehicle attached under its own name prefix, its own speed in the native block).
    A thread takes the longest runs waiting, so that the threads finish together. When one
    of its runs ends, the longest run waiting of the same layout and timestep takes its
    place (the model's speed for that vehicle changes, nothing else); when half of its
    places are empty, the runs still going continue where they are in a new model, with
    runs waiting of any layout. A numerical failure while packed is put down to its runs
    one by one, each run again on its own. `finished(k, result, seconds)`, if given, is
    told each result as soon as it is known, from the thread that stepped it: k its
    place in `requests`, seconds its share of the threads' time. Once `stop` is set, the
    threads stop after their chunk (the runs not finished have no result: None). With `keep`
    false a run is dropped once `finished` has been told it (its result in the list is None): a
    sweep holds the runs being stepped, not every run's record till the end."""
    results: list = [None] * len(requests)

    def done(k: int, result, seconds: float) -> None:
        if keep or isinstance(result, Exception):
            results[k] = result
        if finished is not None:
            finished(k, result, seconds)

    def put_all() -> None:
        """Prepare the requests, the longest first, for the threads to take as they come."""
        for k in sorted(range(len(requests)), key=lambda k: (-_duration(requests[k]), k)):
            started = time.perf_counter()
            try:
                queue.put(k, prepare(requests[k]))
            except (ValueError, SimulationError) as e:
                done(k, e, time.perf_counter() - started)
        queue.close()

    workers = max(1, min(threads, len(requests)))
    size = min(PACK, -(-len(requests) // workers))  # the first packs: every thread busy
    # A prepared vehicle holds its compiled model and data (0.8 MB a coach): the queue holds
    # those the threads can take next, not every request's (64 coaches: 49 MB).
    queue = _Queue(stop, limit=PACK * workers)
    errors: list[BaseException] = []

    def work() -> None:
        try:
            _work(queue, size, done, derailment_lateral)
        except BaseException as e:
            errors.append(e)
            queue.cancel()

    with native.installed(), stepping():
        # Even one thread steps beside this one, which prepares the runs as places come free.
        pool = [threading.Thread(target=work, name=f"rail-mj-{i}", daemon=True) for i in range(workers)]
        for thread in pool:
            thread.start()
        try:
            put_all()  # while the threads step the first runs prepared
            for thread in pool:
                while thread.is_alive():  # a timeout, so that Ctrl-C is heard
                    thread.join(0.2)
        except BaseException:
            queue.cancel()  # each thread stops after its chunk; the callback stays till then
            for thread in pool:
                thread.join()
            raise
        if errors:
            raise errors[0]
    return results


def _duration(request: Request) -> float:
    """Seconds of simulated time, for the order of the runs (0 for a request to be refused)."""
    try:
        duration = request.distance / request.speed
    except (TypeError, ZeroDivisionError):
        return 0.0
    return duration if math.isfinite(duration) and duration > 0 else 0.0


class _Queue:
    """The runs waiting to be stepped, the longest first, shared by the threads; put in as
    they are prepared, until `close`, and at most `limit` of them at a time (`put` waits)."""

    def __init__(self, stop: threading.Event | None = None, limit: int = PACK):
        self._items: list[tuple[int, Prepared]] = []
        self._ready = threading.Condition()
        self._closed = False
        self._stop = stop or threading.Event()
        self._limit = max(1, limit)

    def put(self, k: int, prepared: Prepared) -> None:
        with self._ready:
            while len(self._items) >= self._limit and not self.cancelled:
                self._ready.wait(0.1)
            self._items.append((k, prepared))
            self._ready.notify_all()

    def close(self) -> None:
        with self._ready:
            self._closed = True
            self._ready.notify_all()

    def cancel(self) -> None:
        self._stop.set()
        self.close()

    @property
    def cancelled(self) -> bool:
        return self._stop.is_set()

    def take(self, n: int, cadence: tuple | None = None) -> list[tuple[int, Prepared]]:
        """Up to n runs of `cadence` (timestep, steps between samples, gravity), the longest first.
        Without one: the first run waiting's, and n of them if n will come (it waits for them)."""
        with self._ready:
            while True:
                if self.cancelled or n <= 0:
                    return []
                like = cadence if cadence is not None or not self._items else self._items[0][1].cadence
                chosen = [item for item in self._items if item[1].cadence == like][:n]
                # A full queue brings no more of this cadence until runs are taken: these then.
                if cadence is not None or self._closed or len(chosen) == n or len(self._items) >= self._limit:
                    break
                self._ready.wait(0.1)
            for item in chosen:
                self._items.remove(item)
            self._ready.notify_all()
            return chosen

    def take_like(self, prepared: Prepared) -> tuple[int, Prepared] | None:
        """The longest run that can take the place of `prepared` in its model: its cadence,
        an equal layout, an equal track and speed profile (so an equal vehicle: both are in its
        model, with its odometer), the speed alone differing."""
        with self._ready:
            for item in self._items:
                request = item[1].request
                if (
                    item[1].cadence == prepared.cadence
                    and _same(request.layout, prepared.request.layout)
                    and request.track == prepared.request.track
                    and request.profile == prepared.request.profile
                ):
                    self._items.remove(item)
                    self._ready.notify_all()
                    return item
            return None


def _same(a: Layout, b: Layout) -> bool:
    try:
        return a is b or bool(a == b)
    except (TypeError, ValueError):  # fields that do not compare (arrays): not known to be equal
        return False


def _work(queue: _Queue, size: int, done, derailment_lateral: float) -> None:
    """One thread's share of `simulate_many`: packs of the longest runs waiting, until none wait."""
    roller = Roller()
    while not queue.cancelled:
        items = queue.take(size)
        if not items:
            return
        drive(Pack([Running(k, p) for k, p in items]), roller, done, derailment_lateral, None, queue)
