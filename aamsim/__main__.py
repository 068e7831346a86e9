from aamsim.entry import main

main()
