"""The viewer's web app: one page (``static/index.html``) and the JSON it reads.

Routes: ``/`` the page; ``/static/...`` its script, style and vendored libraries;
``/api/runs`` the runs and their scenarios; ``/api/scenario?key=RUN/SCENARIO`` one scenario
(scene, status, attempts, variants, files); ``/api/file?key=...&name=...`` one of its files;
``/run/RUN/PATH`` a run folder's own files (its ``report.html`` and what that links to);
``/mining/RUN`` the mining report of the run's records. Served by uvicorn on loopback only.
"""

from __future__ import annotations

from pathlib import Path

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, PlainTextResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from scenweave.errors import InfrastructureError
from scenweave.viewer import catalog

STATIC_DIR = Path(__file__).parent / "static"
INDEX_NAME = "index.html"
VENDOR_SCRIPT = STATIC_DIR / "vendor" / "uPlot.iife.min.js"
#: the only interface the server listens on: the viewer shows local files to a local user
HOST = "127.0.0.1"


class AssetsMissing(InfrastructureError, RuntimeError):
    """The vendored front-end libraries are not there (setup was not run)."""


def check_assets() -> None:
    if not VENDOR_SCRIPT.is_file():
        raise AssetsMissing(f"the viewer's front-end libraries are missing ({VENDOR_SCRIPT}): "
                            "run scripts/setup.d/50-viewer.sh (part of scripts/setup.sh)")


def create_app(paths: list[Path]) -> Starlette:
    """The app showing the runs under ``paths`` (read again on every run-list request, so a
    run that finishes while the page is open appears on reload)."""
    state = {"runs": catalog.find_runs(paths)}

    def runs() -> dict[str, catalog.Run]:
        return state["runs"]

    async def index(request: Request) -> Response:
        return FileResponse(STATIC_DIR / INDEX_NAME, media_type="text/html")

    async def run_list(request: Request) -> Response:
        state["runs"] = catalog.find_runs(paths)
        return _json(catalog.run_list(runs()))

    async def scenario(request: Request) -> Response:
        try:
            return _json(catalog.scenario_detail(runs(), request.query_params.get("key", "")))
        except catalog.NotFound as err:
            return PlainTextResponse(str(err), status_code=404)

    async def file(request: Request) -> Response:
        try:
            return PlainTextResponse(catalog.file_text(runs(), request.query_params.get("key", ""),
                                                       request.query_params.get("name", "")))
        except catalog.NotFound as err:
            return PlainTextResponse(str(err), status_code=404)

    async def run_file(request: Request) -> Response:
        run = runs().get(request.path_params["run"])
        if run is None:
            return PlainTextResponse("no such run", status_code=404)
        root = run.root.resolve()
        path = (root / request.path_params["path"]).resolve()
        if not path.is_relative_to(root) or not path.is_file():
            return PlainTextResponse("no such file in the run", status_code=404)
        return FileResponse(path)

    async def mining(request: Request) -> Response:
        run = runs().get(request.path_params["run"])
        report = catalog.run_row(run).get("mining_report") if run else None
        if report is None:
            return PlainTextResponse("the run's records have no mining report", status_code=404)
        return FileResponse(report, media_type="text/html")

    return Starlette(routes=[
        Route("/", index), Route("/api/runs", run_list), Route("/api/scenario", scenario),
        Route("/api/file", file), Route("/run/{run}/{path:path}", run_file),
        Route("/mining/{run}", mining),
        Mount("/static", StaticFiles(directory=STATIC_DIR), name="static"),
    ])


def _json(data: object) -> Response:
    return Response(catalog.as_json(data), media_type="application/json")


def serve(paths: list[Path], port: int) -> None:
    """Serve the viewer on ``HOST:port`` until interrupted."""
    import uvicorn

    check_assets()
    uvicorn.run(create_app(paths), host=HOST, port=port, log_level="warning")
