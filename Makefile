# AVSP. On a fresh Debian 12 machine (root, or a user with sudo):
#   make demo        install what is missing, build, run the reference traverse headless (results/)
#   make test        install what is missing, build, run every test; prints "N passed, N failed"
# Also: make build, make demo-gui (RViz), make screenshot (RViz under Xvfb -> results/), make clean.
.PHONY: demo demo-gui test build screenshot clean

demo:
	bash tools/avsp.sh demo

demo-gui:
	bash tools/avsp.sh demo --gui

test:
	bash tools/avsp.sh test

build:
	bash tools/avsp.sh build

screenshot:
	bash tools/avsp.sh screenshot

clean:
	rm -rf build install log results
