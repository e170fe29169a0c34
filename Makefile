# defender: the two commands a newcomer needs are `make run` and `make test`.
# Both run `make setup` first (idempotent: it fetches MuJoCo and the Gymnasium task files once).
SHELL := /bin/bash
CARGO ?= cargo
RUN_DIR ?= runs/main

.PHONY: setup run test bench lint fmt tools-venv clean-deps

setup:
	@bash scripts/setup.sh

# The main job: bare SAC and SAC with DEFENDER on a task with the shipped demonstrations,
# then the paper's table and the plots (see README).
run: setup
	@bash scripts/run.sh "$(RUN_DIR)"

test: setup
	$(CARGO) test --release --workspace --all-targets
	# --all-targets leaves out doc tests: the crates' README examples are compiled and run here.
	$(CARGO) test --release --workspace --doc

bench: setup
	$(CARGO) bench --workspace

lint: setup
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --workspace --all-targets -- -D warnings

fmt:
	$(CARGO) fmt --all

# The Python side used by tools/ (golden values, Gymnasium parity recordings, the
# Stable-Baselines3 and dtaidistance comparisons). Not needed for `make test`.
tools-venv: setup
	@bash scripts/tools-venv.sh

clean-deps:
	rm -rf .deps
