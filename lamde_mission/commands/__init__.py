"""One module per CLI command, each with `add_parser(subparsers)` and `run(args) -> int`.

Modules import only what `--help` needs at top level; heavy imports (cvxpy, matplotlib, mavsdk,
torch, numba-compiled code) happen inside `run`, so `lamde-mission --help` stays fast.
"""

#: command modules in the order `--help` lists them; a missing module is skipped
COMMANDS = (
    "plan",
    "verify",
    "show",
    "check",
    "map",
    "schema",
    "generate",
    "mock_vehicle",
    "upload",
    "bench",
    "report",
    "lam",
    "train",
)
