"""argand.farm: the render farm's domain, imported by the HTTP layer
(argand.api) and the workers (argand.worker), importing neither.

By phase of a job's life, one module each:

settings     the one configuration object, passed explicitly
models       the SQL rows (jobs, frames, tiles, workers); database: engines,
             sessions and the Alembic upgrade (migrations/)
states       the job/frame/tile state machines: every change of state goes through them
layout       every file of a job in the store; store: the frame store (atomic writes, tile chunks)
planning     tiles -> runs of tiles -> messages (pure); queue: the messages' contract and sending
submission   a new job (limits, rows, first messages); dispatch: sending a job's queued tiles
tile_work    a worker's task body: claim, render, commit a run of tiles
assembly     tiles -> a frame's files; frames -> the animation
control      cancel, pause, resume, retry, priority, delete
reaper       the work nobody will finish, finished
workers      heartbeats; progress: a job's progress and ETA
previews     false-colour channel pictures; metrics: Prometheus collector
"""
