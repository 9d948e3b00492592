"""`python -m motionclean`: the same command line as the `motionclean` script."""

from motionclean.cli import main

main()
