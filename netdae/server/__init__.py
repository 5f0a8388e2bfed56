"""A warm netdae process that runs command lines: start-up without the start-up.

A netdae command pays for its imports and for numba's initialisation before it
reads a netlist: about 2 s of a 2.5 s run of a small circuit (measured in
``docs/performance.md``). The ``netdae`` console script therefore hands its
command line to a *server*, a netdae process that has paid that once, when one
is running for the same installation; the server forks a worker per command,
which runs it exactly as the command line would, with the caller's arguments,
working directory, environment and standard streams (passed as file
descriptors), and reports its exit status. Ctrl-C and termination signals are
forwarded to the worker, so an interrupted run keeps what it computed as
before.

The first command that loads the compiled engine without a server runs as
usual and then starts one in the background; the server exits after
:data:`~netdae.server.client.IDLE_SECONDS` without a command. The same
mechanism as Mercurial's ``chg`` and Gradle's daemon.

- :mod:`netdae.server.client` -- the console script's side (standard library
  only, no numpy): the installation's key, connecting, forwarding signals,
  starting a server.
- :mod:`netdae.server.serve` -- the server: warm-up, the accept loop, a
  supervisor and a worker per command.

``NETDAE_SERVER=0`` turns it off; ``netdae server status|start|stop`` manages it.
"""

import os as _os

#: Environment variable that turns the server off (``0``, ``no``, ``off``, ``false``).
SWITCH = "NETDAE_SERVER"


def wanted(env=None) -> bool:
    """Whether the environment lets commands go through a server (cheap: no imports)."""
    env = _os.environ if env is None else env
    return env.get(SWITCH, "1").strip().lower() not in ("0", "no", "off", "false")
