from uamtoolkit_import.cli import main

main(prog_name="uam2scn")
