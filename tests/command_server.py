"""A fork server for the commands a test runs as a user types them.

``python tests/command_server.py SOCKET`` imports what every ``eigentwist`` command imports
(NumPy, SciPy, Matplotlib, the package), then serves each connection in a forked child: the
child takes the client's standard streams (passed as file descriptors), working directory,
environment and arguments, runs ``eigentwist.cli.main.main`` as the console script does
(``sys.exit(main())``, exit handlers included) or a Python script as ``python script.py``
does, and the server sends the child's exit status back. Each command thus starts from the
state of a fresh process that has imported the package and nothing more (no memo, no loaded
library), without paying for the imports again. ``client_script`` writes the executables
that connect to it.
"""

from __future__ import annotations

import importlib
import json
import os
import select
import socket
import sys

#: modules imported once by the server (what the commands import, most of their start-up)
PRELOAD = (
    "numpy",
    "scipy.linalg",
    "scipy.optimize",
    "scipy.stats",
    "matplotlib.pyplot",
    "sympy",
    "eigentwist.cli.main",
    "eigentwist.runtime",
    "eigentwist.diagnose",
)
HEADER = 8  # bytes of the request's length, big-endian


def client_script(python: str, path: str, program: str = "eigentwist") -> str:
    """The text of an executable that runs its command in the server at ``path`` and exits
    with the command's status (standard library only: starts in ms): ``program`` is
    ``"eigentwist"`` (its arguments are the command's) or ``"python"`` (its argument is a
    script, run as ``__main__`` with the script's directory first on ``sys.path``)."""
    return f"""#!{python} -IS
import json, os, socket, sys
s = socket.socket(socket.AF_UNIX)
s.connect({path!r})
request = {{"program": {program!r}, "argv": sys.argv[1:], "cwd": os.getcwd(), "env": dict(os.environ)}}
data = json.dumps(request).encode()
socket.send_fds(s, [len(data).to_bytes({HEADER}, "big")], [0, 1, 2])
s.sendall(data)
status = s.makefile().read()
sys.exit(int(status) if status else 1)
"""


def _request(conn: socket.socket) -> tuple[dict, list[int]]:
    head, fds, _, _ = socket.recv_fds(conn, HEADER, 3)
    size = int.from_bytes(head, "big")
    data = b""
    while len(data) < size:
        chunk = conn.recv(size - len(data))
        if not chunk:
            raise ConnectionError("the client closed the connection mid-request")
        data += chunk
    return json.loads(data), fds


def _child(request: dict, fds: list[int]) -> None:
    """Run one command in this forked process; never returns."""
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    code = 1
    try:
        if request["program"] == "python":
            import runpy

            sys.argv = list(request["argv"])
            sys.path[0] = os.path.dirname(os.path.abspath(sys.argv[0]))
            runpy.run_path(sys.argv[0], run_name="__main__")
            sys.exit(0)
        from eigentwist.cli.main import main

        sys.argv = ["eigentwist", *request["argv"]]
        sys.exit(main())
    except SystemExit as stop:
        if stop.code is None or isinstance(stop.code, int):
            code = stop.code or 0
        else:
            print(stop.code, file=sys.stderr)
    except BaseException:
        import traceback

        traceback.print_exc()
    finally:
        import atexit

        atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except OSError:
                pass
    os._exit(code)


def serve(path: str) -> None:
    """Accept commands on the Unix socket ``path`` until the parent closes standard input."""
    for name in PRELOAD:
        importlib.import_module(name)
    server = socket.socket(socket.AF_UNIX)
    server.bind(path)
    server.listen(16)
    print("ready", flush=True)
    waiting: dict[int, socket.socket] = {}
    while True:
        readable, _, _ = select.select([server, sys.stdin], [], [], 0.02)
        if sys.stdin in readable and not sys.stdin.read(1):
            break
        if server in readable:
            conn, _ = server.accept()
            request, fds = _request(conn)
            pid = os.fork()
            if pid == 0:
                for other in (server, conn, *waiting.values()):
                    other.close()
                _child(request, fds)
            for fd in fds:
                os.close(fd)
            waiting[pid] = conn
        while waiting:
            pid, status = os.waitpid(-1, os.WNOHANG)
            if pid == 0:
                break
            code = os.waitstatus_to_exitcode(status)
            conn = waiting.pop(pid)
            conn.sendall(str(code if code >= 0 else 128 - code).encode())
            conn.close()
    server.close()


if __name__ == "__main__":
    serve(sys.argv[1])
