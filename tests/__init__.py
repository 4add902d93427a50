"""shbake's tests: folders mirror the package (docs/ARCHITECTURE.md, "Tests"); each folder is a
package so basenames may repeat across folders and modules import as ``tests.<folder>.<module>``."""
