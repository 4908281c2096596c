# The two commands of the README: `make demo` and `make test`. Each creates .venv
# when missing, installs the package and what it needs, makes sure a usable
# libLLVM (>= 16) exists for Mitsuba's llvm variants, then does its job.
# Everything is idempotent: a second run reinstalls nothing.

PYTHON  ?= python3
VENV    := .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
SCENES  := $(wildcard scenes/*.scn)
OUT     := out

.PHONY: all demo test bench scenes setup llvm povray chromium clean images

all: demo

setup: $(STAMP) llvm

$(PY):
	$(PYTHON) -m venv $(VENV)

# Reinstalled only when the package's metadata changes. setuptools' note that an editable
# install maps folders (converter/ and plugins/ into whitted) is information, not a problem.
# The bytecode is compiled after, on every core (pip compiles file after file).
$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet --upgrade pip
	PYTHONWARNINGS="ignore:Editable installation" $(PY) -m pip install --quiet --no-compile -e '.[test]'
	$(PY) -m compileall -q -j 0 $(VENV)/lib
	touch $(STAMP)

# Finds libLLVM >= 16, or installs Debian's libllvm19 when missing and allowed;
# without one, whitted falls back to the scalar_rgb variant with a warning.
llvm: $(STAMP)
	@WHITTED_VARIANT=scalar_rgb $(PY) -c 'from whitted.variant import ensure_llvm; ensure_llvm()'

# scenes_xml/ is regenerated from scenes/ (every .scn, new ones too): X.xml (the article's
# model, for Python after `import whitted`) and X.portable.xml (stock plugins, any Mitsuba 3).
scenes: setup
	@if [ -f scenes/make_textures.py ]; then $(PY) scenes/make_textures.py; fi
	@mkdir -p scenes_xml
	@$(VENV)/bin/whitted convert scenes/ -o scenes_xml/
	@$(VENV)/bin/whitted convert scenes/ -o scenes_xml/ --portable
	@echo "scenes_xml/ regenerated from scenes/"

# Renders what scenes/ holds now: the .scn files themselves (an edit shows at once),
# after converting them, so that scenes_xml/ matches what was rendered.
demo: scenes
	@mkdir -p $(OUT)/demo
	@for scn in $(SCENES); do \
		name=$$(basename $${scn%.scn}); \
		echo "rendering $$scn"; \
		$(VENV)/bin/whitted render $$scn -o $(OUT)/demo/$$name.png || exit 1; \
		$(VENV)/bin/whitted render $$scn -o $(OUT)/demo/$$name.exr -q || exit 1; \
		$(VENV)/bin/whitted render $$scn -o $(OUT)/demo/$$name-path.png \
			--integrator path --spp 64 -q || exit 1; \
	done
	@echo "demo images in $(OUT)/demo/: NAME.png and NAME.exr (the article's model), NAME-path.png (Mitsuba's path tracer, 64 spp)"

# The README's first picture: scenes/spheres.scn with the article's model and the path tracer;
# and the pictures of docs/lessons.md, rendered by its own commands.
images: setup
	$(PY) docs/images/first_look.py
	$(PY) docs/images/lessons.py

# Debian's Chromium, for the browser test of `whitted compare`'s report page
# (tests/test_compare_page.py skips it without one): installed when missing and
# allowed (root, apt-get, no $WHITTED_NO_APT), as the llvm step installs libllvm19.
chromium:
	@if [ -x /usr/bin/chromium ]; then :; \
	elif [ "$$(id -u)" = 0 ] && [ -z "$$WHITTED_NO_APT" ] && command -v apt-get >/dev/null; then \
		echo "installing Debian's chromium (for the report page's browser test)"; \
		( export DEBIAN_FRONTEND=noninteractive; apt-get -qq update && apt-get -qq install -y chromium >/dev/null ) \
			|| echo "warning: chromium could not be installed; the browser test will be skipped"; \
	else \
		echo "note: no /usr/bin/chromium (as root: apt-get install chromium); the browser test will be skipped"; \
	fi

# in parallel, one worker per core; a test file's tests share a worker (and the renders its
# fixtures make once), but for a few long files split by a parameter, and the slowest files
# start first (tests/conftest.py: SLOW_FIRST, SPLIT). A worker that crashes ends the run,
# naming its test: xdist's replacement worker can wait forever under --dist loadgroup.
test: setup chromium
	$(PY) -m pytest -q -n auto --dist loadgroup --no-loadscope-reorder --max-worker-restart 0

# POV-Ray 3.7 for the side-by-side benchmark: Debian's povray, installed when missing and
# allowed (root, or sudo without a password), like the llvm step; otherwise its rows say why.
povray:
	@if command -v povray >/dev/null; then :; \
	elif [ -z "$$WHITTED_NO_APT" ] && command -v apt-get >/dev/null \
			&& { [ "$$(id -u)" = 0 ] && sudo= || { sudo -n true 2>/dev/null && sudo="sudo -n"; }; }; then \
		echo "make bench: installing POV-Ray (apt-get install povray)" >&2; \
		export DEBIAN_FRONTEND=noninteractive; $$sudo apt-get -qq update >/dev/null; \
		$$sudo apt-get -qq install -y povray >/dev/null; \
	fi
	@command -v povray >/dev/null || echo "make bench: POV-Ray is not installed and cannot be installed \
	here (needs apt-get and root); the benchmark's POV-Ray rows will say so" >&2

# Speed against Mitsuba's own integrators and the ray-casting floor, then against POV-Ray 3.7
# on the sphereflake, levels 1-6 on floors of radius 10^3 and 10^4, with Mitsuba's path tracer
# (`whitted render --integrator path --spp 1`) beside whitted's render (benchmarks/RESULTS.md), then
# a 48-frame sequence by POV-Ray and whitted a process per frame against `whitted render FRAMES/`
# in one process (benchmarks/frames.py); `make bench BENCHFLAGS=--quick` for a short run.
BENCHFLAGS ?=
bench: setup povray
	$(PY) -m benchmarks.run $(BENCHFLAGS)
	$(PY) -m benchmarks.vs_povray $(BENCHFLAGS)
	$(PY) -m benchmarks.frames $(BENCHFLAGS)

clean:
	rm -rf $(OUT) .pytest_cache .hypothesis
