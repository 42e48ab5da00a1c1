from taptune.cli import entry

entry()
