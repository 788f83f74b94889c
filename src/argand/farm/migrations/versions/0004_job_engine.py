"""A job keeps the engine's modes it is rendered with (EngineOptions as
JSON): every worker host renders the job's tiles with them and the API
decides its bands and on-request EXRs with them, whatever each process's
own environment says. Jobs stored before have NULL: the defaults, which is
what every process rendered them with unless its environment said
otherwise.

Revision ID: 0004
Revises: 0003
Create Date: 2026-12-05
"""
import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("jobs", sa.Column("engine", sa.JSON(), nullable=True))


def downgrade() -> None:
    op.execute("ALTER TABLE jobs DROP COLUMN engine")
