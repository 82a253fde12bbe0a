"""Web clients for the live-view load test, run as a separate process (as browsers are).

``python load_clients.py PORT N LINGER_S``: N clients connect at once; every fifth
fetches ``/api/state``, the others follow ``/events`` (the full state, then deltas for
LINGER_S seconds). Prints one JSON line: per client the bytes of the full state, the
events after it, and for client 0 the parsed full state's points per firefighter.
"""
from __future__ import annotations

import json
import socket
import sys
import threading
import time


def _connect(port: int, path: str) -> tuple[socket.socket, bytes]:
    s = socket.create_connection(("127.0.0.1", port), timeout=120)
    s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
    buf = b""
    while b"\r\n\r\n" not in buf:
        got = s.recv(65536)
        if not got:
            raise ConnectionError("closed during the headers")
        buf += got
    head, rest = buf.split(b"\r\n\r\n", 1)
    if not head.startswith(b"HTTP/1.1 200"):
        raise ConnectionError(head.split(b"\r\n")[0].decode())
    return s, head + b"\r\n\r\n" + rest


def state_client(port: int) -> dict:
    s, buf = _connect(port, "/api/state")
    head, body = buf.split(b"\r\n\r\n", 1)
    length = int([ln for ln in head.split(b"\r\n") if ln.lower().startswith(b"content-length")][0]
                 .split(b":")[1])
    chunks = [body]
    got = len(body)
    while got < length:
        part = s.recv(1 << 20)
        if not part:
            break
        chunks.append(part)
        got += len(part)
    s.close()
    return {"kind": "state", "full_bytes": got, "complete": got == length,
            "body": b"".join(chunks)}


def events_client(port: int, linger: float) -> dict:
    s, buf = _connect(port, "/events")
    body = buf.split(b"\r\n\r\n", 1)[1]
    chunks, tail = [body], body[-1:]
    while b"\n\n" not in (body if len(chunks) == 1 else tail):
        part = s.recv(1 << 20)
        if not part:
            raise ConnectionError("closed during the full state")
        chunks.append(part)
        if b"\n\n" in tail + part:
            break
        tail = part[-1:]
    data = b"".join(chunks)
    end = data.index(b"\n\n")
    first, rest = data[:end], data[end + 2:]
    events = rest.count(b"data: ")
    until = time.monotonic() + linger
    s.settimeout(1.0)
    while time.monotonic() < until:
        try:
            part = s.recv(1 << 16)
        except socket.timeout:
            continue
        if not part:
            break
        events += part.count(b"data: ")
    s.close()
    return {"kind": "events", "full_bytes": len(first), "events_after": events,
            "body": first[len(b"data: "):]}


def main() -> None:
    port, n, linger = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
    results: list[dict | None] = [None] * n

    def run(i: int) -> None:
        try:
            results[i] = state_client(port) if i % 5 == 4 else events_client(port, linger)
        except Exception as exc:  # reported, counted by the test
            results[i] = {"kind": "error", "error": repr(exc)}

    threads = [threading.Thread(target=run, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    first = json.loads(results[0]["body"]) if results[0].get("body") else {}
    points = {a: len(p) for a, p in first.get("tracks", {}).items()}
    for r in results:
        r.pop("body", None)
    print(json.dumps({"clients": results, "points": points}))


if __name__ == "__main__":
    main()
