"""One router per resource: jobs, frames (a job's files), service."""
