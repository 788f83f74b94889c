"""(σ, δ) jobs: each frame's place in its job's grid (its row, the σ index,
and its column, the δ index, for the atlas and the player's two sliders);
the job's single σ goes, as a job's frames may now have many.

Frames of earlier jobs, all of one σ, become row 0 with their index as
column. The column is dropped in place (ALTER TABLE ... DROP COLUMN, SQLite
3.35+ and PostgreSQL): a batch copy of the jobs table would drop the old
table, and with foreign keys on that deletes every frame and tile.

Revision ID: 0003
Revises: 0002
Create Date: 2026-12-02
"""
import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("frames", sa.Column("sigma_index", sa.Integer(), nullable=False, server_default="0"))
    op.add_column("frames", sa.Column("delta_index", sa.Integer(), nullable=False, server_default="0"))
    op.execute('UPDATE frames SET delta_index = "index"')
    op.execute("ALTER TABLE jobs DROP COLUMN sigma")


def downgrade() -> None:
    op.add_column("jobs", sa.Column("sigma", sa.Float(), nullable=False, server_default="0"))
    op.execute("UPDATE jobs SET sigma = (SELECT MIN(frames.sigma) FROM frames WHERE frames.job_id = jobs.id) "
               "WHERE EXISTS (SELECT 1 FROM frames WHERE frames.job_id = jobs.id)")
    op.execute('ALTER TABLE frames DROP COLUMN delta_index')
    op.execute('ALTER TABLE frames DROP COLUMN sigma_index')
