"""The extension's web server (FastAPI): BlueOS's service registration, the page, and its small JSON API.

Every URL the page uses is relative (``v1/status``, not ``/v1/status``), so it works where BlueOS ≥ 1.4
serves it, under ``/extensionv2/wavekeep/``, as well as on its own port.

    GET  /register_service   BlueOS's discovery: name, description, icon, company, version, webpage, api
    GET  /                   the page (HTML)
    GET  /v1/status          link, engaged, forecast age and skill, law and live errors (JSON)
    POST /v1/engage          engage (refused, 409, with the reason, when it may not)
    POST /v1/release         hand the vehicle back to the pilot
    GET  /v1/settings        the settings and their choices
    PUT  /v1/settings        new settings (JSON object; 400 with the reason when one is bad)
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse

from . import __version__
from .settings import LAWS, METHODS, SettingsError, gain_presets
from .status import status

__all__ = ["SERVICE", "create_app"]

PAGE = Path(__file__).with_name("static") / "index.html"
DESCRIPTION = "Wave feed-forward station keeping for the BlueROV2 Heavy, flying through ArduSub"
SERVICE = {
    "name": "Wavekeep",
    "description": DESCRIPTION,
    "icon": "mdi-waves",
    "company": "Wavekeep",
    "version": __version__,
    "webpage": "https://github.com/wavekeep/wavekeep",
    "api": "/docs",
    "route": "/",
    "new_page": False,
    "works_in_relative_paths": True,
}
"""``GET /register_service``: what BlueOS's helper reads to list the extension in its menu."""


def create_app(service) -> FastAPI:
    """The application around a :class:`~blueos.service.CompanionService` (started or not)."""
    app = FastAPI(title="Wavekeep", version=__version__, description=DESCRIPTION)
    page = PAGE.read_text(encoding="utf-8")

    @app.get("/register_service")
    def register_service() -> dict[str, Any]:
        return SERVICE

    @app.get("/", response_class=HTMLResponse)
    def index() -> str:
        return page

    @app.get("/v1/status")
    def get_status() -> dict[str, Any]:
        return status(service)

    @app.post("/v1/engage")
    def engage() -> JSONResponse:
        ok, message = service.request("engage")
        return JSONResponse({"ok": ok, "message": message}, status_code=200 if ok else 409)

    @app.post("/v1/release")
    def release() -> JSONResponse:
        ok, message = service.request("release")
        return JSONResponse({"ok": ok, "message": message}, status_code=200 if ok else 409)

    @app.get("/v1/settings")
    def get_settings() -> dict[str, Any]:
        return {"settings": service.settings.as_dict(), "error": service.settings_error,
                "choices": {"law": LAWS, "gains": list(gain_presets()), "method": list(METHODS)}}

    @app.put("/v1/settings")
    async def put_settings(request: Request) -> JSONResponse:
        try:
            doc = json.loads(await request.body() or b"null")
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            return JSONResponse({"error": f"settings: not JSON ({exc})"}, status_code=400)
        try:
            new = service.apply(doc)
        except SettingsError as exc:
            return JSONResponse({"error": str(exc)}, status_code=400)
        return JSONResponse({"settings": new.as_dict()})

    return app
