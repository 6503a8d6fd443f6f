"""The pacer of a team engine: it runs the steps on one thread while that is faster than the
team (a core taken by another process), and gives them back to the team when it recovers."""

from ballmill.dem.team import Pacer

N = 500


def launch(pacer: Pacer, rates: dict[str, float], remaining: int = 20_000) -> tuple[str, int]:
    """One launch as the engine makes it: plan, run at `rates` (particle-steps/s), record."""
    kind, steps = pacer.plan(remaining)
    pacer.record(kind, steps, N * steps / rates[kind])
    return kind, steps


def test_a_team_ahead_of_one_thread_keeps_the_steps_after_one_short_probe():
    pacer, rates = Pacer(N, 2), {"team": 1.2e7, "serial": 8e6}
    kinds = [launch(pacer, rates, 6_000) for _ in range(40)]  # each team launch: 0.25 s
    assert kinds[:3] == [("team", 6_000)] * 3  # the first compiles (untimed), then 0.5 s
    assert kinds[3] == ("serial", round(Pacer.PROBE_S * 1.2e7 / N))  # early in the run
    assert [k for k, _ in kinds[4:]] == ["team"] * 36 and pacer.current == "team"


def test_a_team_slowed_by_a_busy_core_hands_its_steps_to_one_thread_then_takes_them_back():
    pacer = Pacer(N, 2)
    for _ in range(40):
        launch(pacer, {"team": 1.2e7, "serial": 8e6})
    busy = {"team": 3.5e6, "serial": 8e6}  # the BPR 19 mill with a busy loop on one of two cores
    for _ in range(5):
        launch(pacer, busy)
    assert pacer.current == "serial"
    tries = [launch(pacer, busy)[0] for _ in range(40)]  # 1.25 s each: the team is tried again and loses
    at = [k for k, kind in enumerate(tries) if kind == "team"]
    assert pacer.current == "serial" and len(at) == 3
    assert at[2] - at[1] > at[1] - at[0] > 1  # waiting longer each time
    for _ in range(40):
        launch(pacer, {"team": 1.2e7, "serial": 8e6})
    assert pacer.current == "team"
