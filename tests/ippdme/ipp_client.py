"""A minimal I++ DME client written from the 1.4.3 spec for the tests (shares no code with pcmm_geo.ippdme).

It sends one command at a time and collects every response line of its tag up to the
transaction complete (``TTTTT %``); lines of other tags (events, E0000) are kept aside.
"""

from __future__ import annotations

import re
import socket
import time

_LINE = re.compile(r"^([0-9]{5}|E[0-9]{4}) ([&%#!])(?: (.*))?$")
_PROP = re.compile(r"([A-Za-z][A-Za-z0-9.]*)\(\s*([^()]*)\)")


class Reply:
    """The lines of one transaction: ``data`` (text after ``#``), ``errors`` ((severity, number, text))."""

    def __init__(self, lines: list[str]) -> None:
        self.lines = lines
        self.data: list[str] = []
        self.errors: list[tuple[int, int, str]] = []
        self.acked = False
        self.complete = False
        for line in lines:
            m = _LINE.match(line)
            assert m, f"malformed response line {line!r}"
            kind, rest = m.group(2), m.group(3) or ""
            if kind == "&":
                self.acked = True
            elif kind == "%":
                self.complete = True
            elif kind == "#":
                self.data.append(rest)
            else:
                em = re.match(r'Error\(\s*(\d)\s*,\s*(\d{4})\s*,\s*"[^"]*"\s*,\s*"([^"]*)"\s*\)$', rest)
                assert em, f"malformed error line {line!r}"
                self.errors.append((int(em.group(1)), int(em.group(2)), em.group(3)))

    @property
    def numbers(self) -> list[int]:
        return [e[1] for e in self.errors]

    def values(self) -> dict[str, list[float]]:
        """Numbers of every ``Name(v, ...)`` item of the data lines."""
        out: dict[str, list[float]] = {}
        for text in self.data:
            for name, inner in _PROP.findall(text):
                out[name] = [float(v) for v in inner.split(",") if v.strip() and not v.strip().startswith('"')]
        return out


class IppClient:
    """Blocking TCP client: ``send("GoTo(X(1))")`` numbers the tag itself."""

    def __init__(self, port: int, host: str = "127.0.0.1", timeout: float = 20.0) -> None:
        self.sock = socket.create_connection((host, port), timeout=timeout)
        self.buffer = b""
        self.tag = 0
        self.other: list[str] = []

    def close(self) -> None:
        self.sock.close()

    def readline(self) -> str:
        while b"\r\n" not in self.buffer:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("server closed the connection")
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\r\n", 1)
        return line.decode("ascii")

    def raw(self, data: bytes) -> None:
        self.sock.sendall(data)

    def collect(self, tag: str) -> Reply:
        lines: list[str] = []
        while True:
            line = self.readline()
            if line.startswith(tag + " "):
                lines.append(line)
                if line == f"{tag} %":
                    return Reply(lines)
            else:
                self.other.append(line)

    def send(self, method: str, *, event: bool = False) -> Reply:
        self.tag += 1
        tag = f"E{self.tag % 10000:04d}" if event else f"{self.tag:05d}"
        self.raw(f"{tag} {method}\r\n".encode("ascii"))
        return self.collect(tag)

    def wait_other(self, count: int, timeout: float = 5.0) -> list[str]:
        """Read lines until ``count`` lines of other tags arrived (events), within ``timeout`` s."""
        end = time.monotonic() + timeout
        self.sock.settimeout(0.2)
        try:
            while len(self.other) < count and time.monotonic() < end:
                try:
                    self.other.append(self.readline())
                except TimeoutError:
                    continue
        finally:
            self.sock.settimeout(20.0)
        return self.other


def num(x: float) -> str:
    """A number as the spec allows it (at most 16 digits)."""
    return f"{x:.6f}"
