"""Argand's tests, one folder per package of src/argand; helpers/ holds the independent oracles."""
