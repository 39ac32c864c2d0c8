"""How often MAVSDK gives up one mission item on a lossy link: a model of its transfer client.

MAVSDK 4.1's MavlinkMissionTransferClient (cpp/src/mavsdk/core/mavlink_mission_transfer_client.cpp)
counts, per item, up to `retries = 5` (a constant in its .hpp):

- download: each MISSION_REQUEST_INT it sends; after a silence of one message timeout it asks
  again; once 5 requests are out and the timeout passes again the list fails (TIMEOUT). A new
  item resets the count.
- upload: each send of the item (MAVSDK sends it only when the vehicle asks for it) and each
  silence of one message timeout (it sends nothing then); a request for the item after the count
  reached 5, or a timeout at 5, fails the list. A request for the next item resets the count.
  The vehicle asks again `period` s after its last request (PX4 0.25 s, ArduPilot 1 s; see
  `lamde_mission.vehicle.mock.UPLOAD_TIMING`).

Each message is lost with probability `p`, independently, both ways; no latency. Monte Carlo for
the upload (timing matters), closed form for the download. Where MAVSDK's timer and the vehicle's
re-request fall on the same instant (0.5 s is two PX4 periods; 0.5 and 1 s against ArduPilot's
1 s) which comes first decides whether that silence is counted; on a real link either may, so the
upload rows give both: the timer first (pessimistic) and the request first (optimistic). Prints
the per-item failure rate and what it makes of a whole list of `--items` items (T16's plan: 19
mission + 295 fence = 314):

    python benchmarks/mavsdk_retry_model.py [--items 314] [--trials 200000] [--seed 1]
"""

from __future__ import annotations

import argparse
import random

RETRIES = 5  # MAVSDK: static constexpr unsigned retries = 5


def download_item_fails(p: float) -> float:
    """Five request/answer round trips, each through with (1-p)^2, all lost."""
    return (1.0 - (1.0 - p) ** 2) ** RETRIES


def upload_item_fails(
    p: float, period: float, timeout: float, rng: random.Random, timer_first: bool = True
) -> bool:
    """One upload item, from MAVSDK hearing the vehicle's first request for it at t = 0;
    `timer_first`: MAVSDK's timer wins a tie with the vehicle's re-request."""
    count, deadline = 1, timeout  # sent once; MAVSDK's timer armed
    last_request = 0.0  # when the vehicle last asked (for this item, or the next)
    delivered = rng.random() >= p
    if delivered and rng.random() >= p:  # the vehicle asks for the next item at once: heard
        return False
    while True:
        ask = last_request + period
        if deadline < ask or (timer_first and deadline == ask):
            # MAVSDK's timer first: a silence counts, nothing is sent
            if count >= RETRIES:
                return True
            count += 1
            deadline += timeout
            continue
        last_request = ask
        if rng.random() < p:  # the request is lost
            continue
        if delivered:  # it was a request for the next item: this one is done
            return False
        if count >= RETRIES:
            return True
        count += 1  # sent again
        deadline = ask + timeout
        delivered = rng.random() >= p
        if delivered and rng.random() >= p:
            return False


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--items", type=int, default=314)
    ap.add_argument("--trials", type=int, default=200_000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    n = args.items
    print(f"per item, and for a list of {n} items; {args.trials} trials per upload row; upload "
          "rows: MAVSDK's timer first / the vehicle's request first at a tie")
    print(f"{'loss':>5} {'transfer':<42} {'item fails':>17} {'list ok':>17}")
    for p in (0.05, 0.2, 0.4):
        q = download_item_fails(p)
        print(f"{p:5.2f} {'download (any message timeout)':<42} {q:17.5f} {(1 - q) ** n:17.3g}")
        for vehicle, period in (("PX4", 0.25), ("ArduPilot", 1.0)):
            for timeout in (0.5, {"PX4": 1.0, "ArduPilot": 1.6}[vehicle]):
                qs = [sum(upload_item_fails(p, period, timeout, rng, first)
                          for _ in range(args.trials)) / args.trials
                      for first in (True, False)]  # fmt: skip
                what = f"upload to {vehicle}, MAVSDK timeout {timeout:g} s"
                items = " / ".join(f"{q:.5f}" for q in qs)
                lists = " / ".join(f"{(1 - q) ** n:.3g}" for q in qs)
                print(f"{p:5.2f} {what:<42} {items:>17} {lists:>17}")
        print(f"{p:5.2f} {'upload, lower bound p^5':<42} {p**RETRIES:17.5f} "
              f"{(1 - p**RETRIES) ** n:17.3g}")  # fmt: skip


if __name__ == "__main__":
    main()
