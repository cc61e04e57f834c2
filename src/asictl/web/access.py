"""Who may change the board over HTTP (docs/security.md, "The web server").

Read-only unless the server was started with ``--http-writable``; then a write needs the
token (``--http-token-file FILE`` or ``$ASICTL_HTTP_TOKEN``: there is no default), either

- sent by a script as ``Authorization: Bearer TOKEN`` (no cookie, no CSRF token), or
- given once on the page's login form: the page then holds a session cookie (HttpOnly,
  SameSite=Strict) and sends its CSRF token, derived from the session, in the
  ``X-CSRF-Token`` header of every write; a form another site posts has neither.

Tokens are compared in constant time (``hmac.compare_digest``) and never logged.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from collections import OrderedDict
from dataclasses import dataclass, field

from asictl.errors import ExitCode, UserError

#: The page's session cookie and the header its writes carry the CSRF token in.
COOKIE = "asictl_session"
CSRF_HEADER = "x-csrf-token"
#: Environment variable of the token (as $ASICTL_OPCUA_PASSWORD for OPC UA).
TOKEN_ENV = "ASICTL_HTTP_TOKEN"
#: Sessions kept at once: the oldest is forgotten (its page logs in again).
MAX_SESSIONS = 64
#: A token shorter than this is refused: it could be guessed.
MIN_TOKEN = 16


def check_token(token: str | None, *, writable: bool) -> None:
    """Writes need a token, and one that cannot be guessed."""
    if writable and token is None:
        raise UserError(f"--http-writable needs a token: --http-token-file FILE or ${TOKEN_ENV}",
                        ExitCode.USAGE)
    if token is not None and len(token) < MIN_TOKEN:
        raise UserError(f"the HTTP token is {len(token)} characters long: give at least "
                        f"{MIN_TOKEN} (e.g. python3 -c 'import secrets; "
                        "print(secrets.token_urlsafe())')", ExitCode.USAGE)


@dataclass
class Access:
    """The server's token and the page's sessions (kept in memory: a restart logs out)."""

    writable: bool = False
    token: str | None = field(default=None, repr=False)
    _secret: bytes = field(default_factory=lambda: secrets.token_bytes(32), repr=False)
    _sessions: OrderedDict[str, None] = field(default_factory=OrderedDict, repr=False)

    def token_ok(self, given: str) -> bool:
        if self.token is None:
            return False
        return hmac.compare_digest(given.encode(), self.token.encode())

    def bearer_ok(self, header: str | None) -> bool:
        scheme, _, given = (header or "").partition(" ")
        return scheme.lower() == "bearer" and self.token_ok(given.strip())

    def new_session(self) -> str:
        session = secrets.token_urlsafe(32)
        self._sessions[session] = None
        while len(self._sessions) > MAX_SESSIONS:
            self._sessions.popitem(last=False)
        return session

    def end_session(self, session: str | None) -> None:
        self._sessions.pop(session or "", None)

    def session_ok(self, session: str | None) -> bool:
        return bool(session) and session in self._sessions

    def csrf(self, session: str) -> str:
        return hmac.new(self._secret, session.encode(), hashlib.sha256).hexdigest()

    def csrf_ok(self, session: str | None, given: str | None) -> bool:
        if not self.session_ok(session) or not given:
            return False
        assert session is not None
        return hmac.compare_digest(given.encode(), self.csrf(session).encode())
