"""argand.farm.bands.KeyedLocks: one lock per key (threads asking for one
key run one at a time, other keys do not wait), and none kept once no
thread holds or waits for it."""

from __future__ import annotations

import threading
import time

from argand.farm.bands import KeyedLocks


def test_one_key_runs_one_at_a_time_and_no_lock_outlives_its_users():
    locks = KeyedLocks()
    inside: dict[tuple, int] = {}
    most: dict[tuple, int] = {}
    guard = threading.Lock()

    def work(key: tuple) -> None:
        with locks.hold(key):
            with guard:
                inside[key] = inside.get(key, 0) + 1
                most[key] = max(most.get(key, 0), inside[key])
            time.sleep(0.002)
            with guard:
                inside[key] -= 1

    threads = [threading.Thread(target=work, args=((k % 5,),)) for k in range(60)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert all(not t.is_alive() for t in threads)
    assert most == {(k,): 1 for k in range(5)}  # never two threads inside one key
    assert len(locks) == 0  # and nothing kept afterwards


def test_other_keys_do_not_wait_and_an_exception_releases():
    locks = KeyedLocks()
    entered = threading.Event()
    release = threading.Event()

    def hold_a() -> None:
        with locks.hold(("a",)):
            entered.set()
            release.wait(10)

    t = threading.Thread(target=hold_a)
    t.start()
    assert entered.wait(10)
    done = threading.Event()

    def take_b() -> None:
        with locks.hold(("b",)):
            done.set()

    threading.Thread(target=take_b).start()
    assert done.wait(5)  # key b went in while a was held
    release.set()
    t.join(10)
    try:
        with locks.hold(("c",)):
            raise RuntimeError("boom")
    except RuntimeError:
        pass
    with locks.hold(("c",)):  # released by the exception: not a deadlock
        pass
    assert len(locks) == 0
