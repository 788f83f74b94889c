"""The farm's first schema: jobs, frames, tiles, workers.

Revision ID: 0001
Revises:
Create Date: 2026-12-01
"""
import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "jobs",
        sa.Column("id", sa.String(32), primary_key=True),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("scene_name", sa.String(200), nullable=False),
        sa.Column("scene", sa.JSON(), nullable=False),
        sa.Column("sigma", sa.Float(), nullable=False),
        sa.Column("width", sa.Integer(), nullable=False),
        sa.Column("height", sa.Integer(), nullable=False),
        sa.Column("tile", sa.Integer(), nullable=False),
        sa.Column("method", sa.String(16), nullable=False),
        sa.Column("priority", sa.Integer(), nullable=False),
        sa.Column("created", sa.Float(), nullable=False),
        sa.Column("started", sa.Float(), nullable=True),
        sa.Column("finished", sa.Float(), nullable=True),
        sa.Column("error", sa.Text(), nullable=True),
    )
    op.create_index("ix_jobs_status", "jobs", ["status"])
    op.create_table(
        "frames",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("job_id", sa.String(32), sa.ForeignKey("jobs.id", ondelete="CASCADE"), nullable=False),
        sa.Column("index", sa.Integer(), nullable=False),
        sa.Column("sigma", sa.Float(), nullable=False),
        sa.Column("delta", sa.Float(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("tiles_total", sa.Integer(), nullable=False),
        sa.Column("tiles_done", sa.Integer(), nullable=False, server_default="0"),
        sa.Column("finished", sa.Float(), nullable=True),
        sa.Column("figures", sa.JSON(), nullable=True),
        sa.Column("assembly_s", sa.Float(), nullable=True),
        sa.Column("assembler", sa.String(200), nullable=True),
        sa.Column("assembling_since", sa.Float(), nullable=True),
    )
    op.create_index("ix_frames_job_id", "frames", ["job_id"])
    op.create_table(
        "tiles",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("job_id", sa.String(32), sa.ForeignKey("jobs.id", ondelete="CASCADE"), nullable=False),
        sa.Column("frame_index", sa.Integer(), nullable=False),
        sa.Column("tile_index", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("worker", sa.String(200), nullable=True),
        sa.Column("started", sa.Float(), nullable=True),
        sa.Column("waited", sa.Float(), nullable=True),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("renders", sa.Integer(), nullable=False),
        sa.Column("seconds", sa.Float(), nullable=True),
        sa.Column("chunk", sa.String(64), nullable=True),
    )
    op.create_index("ix_tiles_job_id", "tiles", ["job_id"])
    op.create_index("ix_tiles_frame_index", "tiles", ["frame_index"])
    op.create_index("ix_tiles_status", "tiles", ["status"])
    op.create_index("ix_tiles_key", "tiles", ["job_id", "frame_index", "tile_index"], unique=True)
    op.create_table(
        "workers",
        sa.Column("name", sa.String(200), primary_key=True),
        sa.Column("host", sa.String(200), nullable=False),
        sa.Column("pid", sa.Integer(), nullable=False),
        sa.Column("heartbeat", sa.Float(), nullable=False),
        sa.Column("current_tile", sa.String(200), nullable=True),
        sa.Column("tiles_done", sa.Integer(), nullable=False),
    )


def downgrade() -> None:
    for table in ("workers", "tiles", "frames", "jobs"):
        op.drop_table(table)
