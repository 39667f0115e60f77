"""Alembic's environment for the registry: runs on the connection batlab hands it.

``batlab.registry.migration`` opens the registry, takes its write lock and passes the
connection in ``config.attributes["connection"]``; the migrations run inside that
transaction (no ``alembic.ini``, no logging set-up, no engine of their own).
"""

from alembic import context

from batlab.registry.schema import metadata

context.configure(connection=context.config.attributes["connection"],
                  target_metadata=metadata, render_as_batch=True)
with context.begin_transaction():
    context.run_migrations()
