"""Bearer-token auth for the HTTP transport: one shared secret, checked in constant time (the SDK's
TokenVerifier protocol; its middleware answers 401 without a valid `Authorization: Bearer` header)."""

from __future__ import annotations

import hmac
import ipaddress

from mcp.server.auth.provider import AccessToken, TokenVerifier
from mcp.server.auth.settings import AuthSettings

MIN_TOKEN_CHARS = 16


class StaticTokenVerifier(TokenVerifier):
    def __init__(self, token: str) -> None:
        if len(token) < MIN_TOKEN_CHARS:
            raise ValueError(f"the bearer token must have at least {MIN_TOKEN_CHARS} characters")
        self._token = token.encode()

    async def verify_token(self, token: str) -> AccessToken | None:
        if hmac.compare_digest(token.encode(), self._token):
            return AccessToken(token=token, client_id="fleetnav-bearer", scopes=[])
        return None


def auth_settings(host: str, port: int) -> AuthSettings:
    """This server is its own resource server; tokens are issued out of band (the shared secret)."""
    url = f"http://{host if ':' not in host else f'[{host}]'}:{port}"
    return AuthSettings(issuer_url=url, resource_server_url=None)


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
