"""Who may talk to the commander's page: the Host check and the optional token.

* **Host check** (against DNS rebinding): a web page on another site can make the
  commander's browser resolve its own name to 127.0.0.1 and then read the field kit's
  page as "same origin". The browser still sends that name in the ``Host`` header, so
  a request is served only when its host name is one the kit is reached by: the
  loopback names, the address it listens on, and ``allowed_hosts``.
* **Token** (optional login): when set, every request must carry it, as the cookie the
  page gets by opening ``/?token=...`` once (``HttpOnly``, ``SameSite=Strict``), or as
  ``Authorization: Bearer ...``. Compared in constant time.
* **Acknowledgements** change state, so they must also come from the page itself: a
  ``POST`` whose ``Origin`` (when the browser sends one) names an allowed host.
"""
from __future__ import annotations

import hmac
from http.cookies import CookieError, SimpleCookie
from urllib.parse import urlsplit

__all__ = ["Access", "COOKIE"]

COOKIE = "firenav_view_token"
_LOOPBACK = {"localhost", "127.0.0.1", "::1"}
_WILDCARD = {"", "0.0.0.0", "::"}


def _hostname(value: str) -> str:
    """The host name of a ``Host`` header value or an origin, lower case, no port."""
    value = value.strip().lower()
    if "://" in value:
        return (urlsplit(value).hostname or "").lower()
    if value.startswith("["):  # [::1]:8765
        return value[1:value.find("]")] if "]" in value else ""
    return value.rsplit(":", 1)[0] if value.count(":") == 1 else value


class Access:
    """The checks of one server (see the module docstring)."""

    def __init__(self, bind_host: str, allowed_hosts: list[str] | tuple[str, ...] = (),
                 token: str = ""):
        names = set(_LOOPBACK) | {h.strip().lower() for h in allowed_hosts if h.strip()}
        if bind_host not in _WILDCARD:
            names.add(bind_host.lower())
        self.hosts = frozenset(names)
        self.token = token

    def host_ok(self, host_header: str | None) -> bool:
        """Whether the request's ``Host`` names this kit (a missing header does not)."""
        return bool(host_header) and _hostname(host_header) in self.hosts

    def origin_ok(self, origin: str | None) -> bool:
        """A state-changing request: no ``Origin`` (not a browser) or an allowed one."""
        return origin is None or _hostname(origin) in self.hosts

    def token_ok(self, authorization: str | None, cookie: str | None,
                 query_token: str | None = None) -> bool:
        """Whether the request carries the token (always True when none is set)."""
        if not self.token:
            return True
        offered = []
        if authorization and authorization.startswith("Bearer "):
            offered.append(authorization[len("Bearer "):].strip())
        if cookie:
            try:
                jar = SimpleCookie(cookie)
            except CookieError:
                jar = SimpleCookie()
            if COOKIE in jar:
                offered.append(jar[COOKIE].value)
        if query_token:
            offered.append(query_token)
        want = self.token.encode()
        return any(hmac.compare_digest(o.encode(), want) for o in offered)

    def cookie_header(self) -> str:
        """The ``Set-Cookie`` value that logs a browser in."""
        return f"{COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict"
