"""One connection syntax for both uploaders, validated before anything is opened, and the byte
links the pymavlink client and the mock vehicle use.

Syntax (MAVSDK's URLs, which both clients accept; `lamde-mission upload --connect`):

- `udpin://HOST:PORT`   listen for the vehicle on UDP (HOST may be 0.0.0.0 = all interfaces)
- `udpout://HOST:PORT`  send to a vehicle listening on UDP at HOST:PORT
- `tcpout://HOST:PORT`  connect to a vehicle's TCP server (SITL: `tcpout://127.0.0.1:5760`)
- `tcpin://HOST:PORT`   listen for one TCP connection from the vehicle side
- `serial:///dev/ttyUSB0:57600`  a serial port (telemetry radio, USB) at a baud rate

Accepted spellings: `udp:` = `udpin:`, `tcp:` = `tcpout:`, and `scheme:rest` without `//`
(mavutil's style). `parse_connection` raises ValueError with one line for anything else (unknown
scheme, missing or out-of-range port, a serial device that does not exist or is not a terminal,
a baud rate that is not a standard one); `parse_connections` also refuses a list naming one
address or device twice (two links cannot both open it).
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import stat
import termios
import tty
from dataclasses import dataclass
from urllib.parse import urlsplit

__all__ = ["Connection", "parse_connection", "parse_connections", "Link",
           "BAUD_RATES", "SCHEMES"]  # fmt: skip

SCHEMES = ("udpin", "udpout", "tcpin", "tcpout", "serial")
_ALIASES = {"udp": "udpin", "tcp": "tcpout"}

#: baud rates a serial link may use (termios constants on Linux)
BAUD_RATES = {
    b: getattr(termios, f"B{b}")
    for b in (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 500000,
              576000, 921600, 1000000, 1500000, 2000000)  # fmt: skip
    if hasattr(termios, f"B{b}")
}

_SYNTAX = ("expected udpin://HOST:PORT, udpout://HOST:PORT, tcpout://HOST:PORT, "
           "tcpin://HOST:PORT or serial:///dev/DEVICE:BAUD")  # fmt: skip


@dataclass(frozen=True)
class Connection:
    """A validated connection: `scheme` in SCHEMES; host/port for UDP/TCP, device/baud for
    serial."""

    scheme: str
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = 0

    @property
    def mode(self) -> str:
        """The scheme (kept for code that knew only UDP endpoints).

        Returns:
            `scheme`.
        """
        return self.scheme

    def url(self) -> str:
        """MAVSDK's spelling, e.g. `udpin://0.0.0.0:14540`, `serial:///dev/ttyUSB0:57600`.

        Returns:
            "serial://{device}:{baud}", or "{scheme}://{host}:{port}".
        """
        if self.scheme == "serial":
            return f"serial://{self.device}:{self.baud}"
        return f"{self.scheme}://{self.host}:{self.port}"

    def __str__(self) -> str:
        return self.url()


def parse_connection(text: str, *, check_device: bool = True) -> Connection:
    """Parse and check a connection string (see the module docstring).

    Args:
        text: the connection string (surrounding spaces ignored).
        check_device: also check that a serial device exists and is a character device.

    Returns:
        The `Connection`; an empty udpin/tcpin host is 0.0.0.0.

    Raises:
        ValueError: one line: an unknown scheme, a missing or out-of-range port, anything
            after HOST:PORT, a baud rate not in `BAUD_RATES`, or (with `check_device`) a
            serial device that does not exist or is not a character device.
    """
    raw = str(text).strip()
    scheme, sep, rest = raw.partition(":")
    scheme = _ALIASES.get(scheme.lower(), scheme.lower())
    if not sep or scheme not in SCHEMES:
        raise ValueError(f"{text!r}: unknown connection; {_SYNTAX}")
    if scheme == "serial":
        body = rest[2:] if rest.startswith("//") else rest
        device, colon, baud_s = body.rpartition(":")
        if not colon or not device:
            raise ValueError(f"{text!r}: expected serial:///dev/DEVICE:BAUD")
        if not baud_s.isdigit() or int(baud_s) not in BAUD_RATES:
            known = ", ".join(str(b) for b in BAUD_RATES)
            raise ValueError(f"{text!r}: baud rate {baud_s!r} is not one of {known}")
        if check_device:
            try:
                st = os.stat(device)
            except OSError as exc:
                raise ValueError(f"{text!r}: serial device {device}: "
                                 f"{exc.strerror or exc}") from None  # fmt: skip
            if not stat.S_ISCHR(st.st_mode):
                raise ValueError(f"{text!r}: {device} is not a serial (character) device")
        return Connection("serial", device=device, baud=int(baud_s))
    if rest.startswith("//"):
        if "/" in rest[2:] or "?" in rest or "#" in rest:
            raise ValueError(f"{text!r}: expected {scheme}://HOST:PORT and nothing after it")
        try:
            parts = urlsplit(f"{scheme}:{rest}")
            host, port = parts.hostname or "", parts.port
        except ValueError:
            host, port = "", None
    else:
        host, _, p = rest.rpartition(":")
        port = int(p) if p.isdigit() else None
    if not host and scheme in ("udpin", "tcpin"):
        host = "0.0.0.0"
    if not host or port is None or not 0 < port < 65536:
        raise ValueError(f"{text!r}: expected {scheme}://HOST:PORT with a port 1..65535")
    return Connection(scheme, host=host, port=int(port))


def parse_connections(texts: list[str], *, check_device: bool = True) -> list[Connection]:
    """Parse and check a list of connections, one per vehicle (`upload --fleet --connect
    A,B`): each as `parse_connection`, and none twice. Two links on one serial device, or
    listening (udpin, tcpin) on one port of one address (0.0.0.0 is every address), cannot
    both open it: the second would fail late with "Address already in use".

    Args:
        texts: the connection strings, in vehicle order.
        check_device: as for `parse_connection`.

    Returns:
        The connections, in the order given.

    Raises:
        ValueError: one line, naming a bad entry (`parse_connection`'s) or the one listed
            twice.
    """
    out = [parse_connection(t, check_device=check_device) for t in texts]

    def same(a: Connection, b: Connection) -> bool:
        if a.scheme == "serial" or b.scheme == "serial":
            return a.scheme == b.scheme and a.device == b.device
        wild = a.scheme in ("udpin", "tcpin") and "0.0.0.0" in (a.host, b.host)
        return a.scheme == b.scheme and a.port == b.port and (a.host == b.host or wild)

    for j, b in enumerate(out):
        for k, a in enumerate(out[:j]):
            if same(a, b):
                also = "" if a == b else f" (as {str(texts[k]).strip()})"
                raise ValueError(f"{str(texts[j]).strip()} listed twice{also}")
    return out


# ----------------------------------------------------------------------------- links


class Link:
    """Bytes to and from the vehicle over one connection (non-blocking reads with a wait).

    `recv(wait)` returns [(bytes, source address)] (the address is None for serial and the TCP
    stream's peer for TCP); `send(buf)` writes to the pinned peer (`peer`), which for `udpin`
    and `tcpin` is whoever talked first until `pin` fixes it.
    """

    def __init__(self, conn: Connection) -> None:
        self.conn = conn
        self.peer: tuple[str, int] | None = None
        self._sock: socket.socket | None = None
        self._listen: socket.socket | None = None
        self._fd: int | None = None
        try:
            self._open()
        except OSError:
            self.close()
            raise

    def _open(self) -> None:
        c = self.conn
        if c.scheme in ("udpin", "udpout"):
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self._sock = sock
            if c.scheme == "udpin":
                sock.bind((c.host, c.port))
            else:
                loopback = c.host in ("127.0.0.1", "localhost")
                sock.bind(("127.0.0.1" if loopback else "0.0.0.0", 0))
                self.peer = (socket.gethostbyname(c.host), c.port)
            sock.setblocking(False)
        elif c.scheme == "tcpout":
            sock = socket.create_connection((c.host, c.port), timeout=5.0)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.setblocking(False)
            self._sock = sock
            self.peer = sock.getpeername()[:2]
        elif c.scheme == "tcpin":
            ls = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            ls.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            ls.bind((c.host, c.port))
            ls.listen(1)
            ls.setblocking(False)
            self._listen = ls
        else:  # serial
            fd = os.open(c.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            self._fd = fd
            with contextlib.suppress(termios.error):  # a pty in tests accepts this too
                tty.setraw(fd)
                attrs = termios.tcgetattr(fd)
                attrs[4] = attrs[5] = BAUD_RATES[c.baud]
                termios.tcsetattr(fd, termios.TCSANOW, attrs)

    @property
    def is_open(self) -> bool:
        """Whether the link holds a socket, a listening socket or a device.

        Returns:
            True while it holds one; False once closed.
        """
        return self._sock is not None or self._listen is not None or self._fd is not None

    def close(self) -> None:
        """Close everything (idempotent)."""
        for s in (self._sock, self._listen):
            if s is not None:
                s.close()
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
        self._sock = self._listen = None
        self._fd = None

    def waitables(self) -> list:
        """What `select` can wait on for this link's input right now.

        Returns:
            [the serial file descriptor], or the open sockets (connected and listening);
            empty once closed.
        """
        if self._fd is not None:
            return [self._fd]
        return [s for s in (self._sock, self._listen) if s is not None]

    def recv(self, wait: float) -> list[tuple[bytes, tuple[str, int] | None]]:
        """What arrived within `wait` s; on `tcpin`, the first connection is accepted (and
        pinned as `peer`; later ones are closed) and nothing is returned for that call.

        Args:
            wait: seconds to wait for input (negative as 0).

        Returns:
            [(bytes, source address)]: the address is None for serial and `peer` for TCP;
            at most 64 datagrams or reads; an empty list if nothing (or on a select error).
        """
        waitable = self.waitables()
        if not waitable:
            return []
        try:
            ready, _, _ = select.select(waitable, [], [], max(wait, 0.0))
        except (OSError, ValueError):
            return []
        if not ready:
            return []
        out: list[tuple[bytes, tuple[str, int] | None]] = []
        if self._listen is not None and self._listen in ready:
            try:
                sock, addr = self._listen.accept()
            except OSError:
                return out
            if self._sock is None:  # one vehicle: the first to connect
                sock.setblocking(False)
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._sock, self.peer = sock, addr[:2]
            else:
                sock.close()
            return out
        if self._fd is not None:
            with contextlib.suppress(BlockingIOError, InterruptedError, OSError):
                data = os.read(self._fd, 65536)
                if data:
                    out.append((data, None))
            return out
        sock = self._sock
        assert sock is not None
        for _ in range(64):
            try:
                if sock.type == socket.SOCK_DGRAM:
                    data, addr = sock.recvfrom(65536)
                else:
                    data, addr = sock.recv(65536), self.peer
                    if not data:  # the vehicle closed the TCP connection
                        sock.close()
                        self._sock = None
                        break
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                break
            out.append((data, addr[:2] if addr else None))
        return out

    def send(self, buf: bytes) -> None:
        """Write `buf` to the peer; nothing if no peer yet (udpin/tcpin before the vehicle).

        Args:
            buf: the bytes (a packed MAVLink message).

        Raises:
            OSError: the write failed.
        """
        if self._fd is not None:
            os.write(self._fd, buf)
        elif self._sock is not None and self.peer is not None:
            if self._sock.type == socket.SOCK_DGRAM:
                self._sock.sendto(buf, self.peer)
            else:
                self._sock.sendall(buf)
