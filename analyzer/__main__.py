"""``python -m analyzer``, and the file ``spark-submit`` runs as a driver
(docs/spark.md): run as a file, its folder would come first on ``sys.path`` and
its modules would shadow top-level names, so the folder is taken off and the
package is imported from where it is installed."""

import os
import sys

if __name__ == "__main__" and not __package__ and sys.path and \
        os.path.abspath(sys.path[0]) == os.path.dirname(os.path.abspath(__file__)):
    sys.path.pop(0)

from analyzer.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
