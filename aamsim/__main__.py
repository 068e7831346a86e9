from aamsim.cli import main

main()
