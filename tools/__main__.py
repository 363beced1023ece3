from tools.main import main

raise SystemExit(main())
