from taptune.cli import main

raise SystemExit(main())
