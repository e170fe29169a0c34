# defender: the two commands a newcomer needs are `make run` and `make test`.
# Both run `make setup` first (idempotent: it fetches MuJoCo and the Gymnasium task files once).
SHELL := /bin/bash
CARGO ?= cargo
RUN_DIR ?= runs/main

.PHONY: setup run test bench bench-peers bench-omnisafe lint fmt tools-venv clean-deps python test-python test-sb3 wheel test-wheel test-safety-gym test-omnisafe

setup:
	@bash scripts/setup.sh

# The main job: bare SAC and SAC with DEFENDER on a task with the shipped demonstrations,
# then the paper's table and the plots (README; docs/cli.md, "`make run` and `make test`").
run: setup
	@bash scripts/run.sh "$(RUN_DIR)"

test: setup
	$(CARGO) test --release --workspace --all-targets
	# --all-targets leaves out doc tests: the crates' README examples are compiled and run here.
	$(CARGO) test --release --workspace --doc
	$(MAKE) --no-print-directory test-python
	# One make for both, so that the wheel they test is built once.
	$(MAKE) --no-print-directory test-wheel test-safety-gym

bench: setup
	$(CARGO) bench --workspace

# Training throughput beside Stable-Baselines3 and SBX (installs them into .deps/tools-venv:
# a multi-GB download the first time), one table; BENCH_ARGS="--threads 1 --repeats 3" etc.
bench-peers: setup
	@bash scripts/bench-peers.sh

# Our SAC and Lagrangian SAC (limit 25) beside OmniSafe's SACLag on SafetyHopperVelocity-v1, one
# thread each, interleaved (tools/peers/bench_peers.py; installs OmniSafe into .deps/omnisafe-venv first,
# tools/peers/omnisafe-venv.sh: a multi-GB download the first time). BENCH_ARGS="--repeats 5" etc.
bench-omnisafe: setup
	@bash tools/peers/omnisafe-venv.sh
	$(CARGO) build --release -p defender-cli
	.deps/venv/bin/python tools/peers/bench_peers.py --env SafetyHopperVelocity-v1 --algos sac,saclag \
		--peers omnisafe --threads 1 $(BENCH_ARGS)

lint: setup
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --workspace --all-targets -- -D warnings

fmt:
	$(CARGO) fmt --all

# The Python side used by tools/ (golden values, Gymnasium parity recordings, the
# Stable-Baselines3 and dtaidistance comparisons). Not needed for `make test`.
tools-venv: setup
	@bash scripts/tools-venv.sh

# The Python package defender-rl (docs/python.md): the wheel built by maturin from
# crates/defender-py and python/, installed into .deps/venv with python/requirements-test.txt.
python: setup
	@bash scripts/python.sh

# The Python tests (part of `make test`). pytest exits non-zero (5) when it collects no test.
test-python: python
	.deps/venv/bin/python -m pytest python/tests -q -p no:cacheprovider

# The wheel a user installs without Rust (docs/python.md): dist/defender_rl-*-cp310-abi3-
# manylinux_2_17_x86_64.whl with the `defender` command, and the sdist. Tools: .deps/wheel-venv.
wheel: setup
	@bash scripts/wheel.sh

# That wheel in a fresh venv, as a user gets it (part of `make test`): no cargo, no source tree;
# the command, a short training, the Gymnasium wrapper, and a two-node Ray cluster losing a node.
test-wheel: wheel
	@bash scripts/test-wheel.sh

# That wheel beside safety-gymnasium 1.0.0 (part of `make test`): a fresh Python 3.10 venv with
# numpy 1.23.5, gymnasium 0.28.1 and mujoco 2.3.3, none of which the install may change; `pip
# check`; the wrapper and cost-labelled demonstrations on Safety-Gymnasium tasks. Skipped with a
# banner where no Python 3.10 is found (scripts/test-beside-safety-gym.sh).
test-safety-gym: wheel
	@bash scripts/test-beside-safety-gym.sh

# Opt-in: Stable-Baselines3 + PyTorch from PyPI (a multi-GB install): SAC with and without
# DEFENDER on InvertedDoublePendulum-v5, and the DefenderCallback.
test-sb3: python
	.deps/venv/bin/python -m pip install --quiet --disable-pip-version-check -r python/requirements-sb3.txt
	.deps/venv/bin/python -m pytest python/tests_sb3 -q -p no:cacheprovider

# Opt-in, not part of `make test`: OmniSafe's SACLag and PPOLag trained a few thousand steps each on
# a DEFENDER-wrapped SafetyHopperVelocity-v1 through OmniSafe's API (tools/peers/omnisafe_defender.py), in
# OmniSafe's venv (tools/peers/omnisafe-venv.sh: about 6 GB); the wheel goes in without changing any of
# its packages (scripts/test-omnisafe.sh).
test-omnisafe: wheel
	@bash scripts/test-omnisafe.sh

clean-deps:
	rm -rf .deps
