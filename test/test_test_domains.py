"""The suite's ROS domain allocation: a domain another process holds is never handed out again."""
import subprocess
import sys

import conftest


def test_a_domain_held_by_another_process_is_skipped():
    first, lock = conftest._claim_domain()
    lock.close()
    nxt = first + 1 if first < 199 else 100  # the id the next claim would take
    claimed = []
    held_elsewhere = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, sys; f = open(sys.argv[1], 'w'); fcntl.flock(f, fcntl.LOCK_EX); "
         "print('held', flush=True); sys.stdin.read()", str(conftest._DOMAIN_LOCKS / f"{nxt}.lock")],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert held_elsewhere.stdout.readline().strip() == "held"
        claimed += [conftest._claim_domain() for _ in range(3)]
        numbers = [n for n, _ in claimed]
        assert nxt not in numbers and len(set(numbers)) == 3
        assert all(100 <= n <= 199 for n in numbers)
    finally:
        held_elsewhere.communicate("")
        for _, lock in claimed:
            lock.close()
