"""A collector-like writer process: ``python pg_writer.py DSN LOGGER FIRST COUNT``.

Writes rows FIRST .. FIRST+COUNT-1 of LOGGER to PostgreSQL in batches of 50 rows through the
real sink; prints the number of rows it inserted as new.
"""

from __future__ import annotations

import asyncio
import sys

from readings_gen import rows

from sondalog.collect import sink_postgres


async def main(dsn: str, logger: str, first: int, count: int) -> None:
    sink = sink_postgres.create({"dsn": dsn})
    await sink.open()
    for start in range(first, first + count, 50):
        await sink.write(rows(logger, start, min(50, first + count - start)))
    await sink.close()
    print(sink.inserted)


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])))
