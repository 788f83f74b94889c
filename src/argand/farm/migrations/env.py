"""Alembic's environment for the farm: runs the revisions on the engine that
argand.farm.database.alembic_config hands over (online only)."""

from alembic import context

from argand.farm.models import Base

engine = context.config.attributes["engine"]
with engine.connect() as connection:
    context.configure(connection=connection, target_metadata=Base.metadata, render_as_batch=True)
    with context.begin_transaction():
        context.run_migrations()
    connection.commit()
