"""kombu's filesystem transport with atomic message files (the embedded broker).

kombu's own ``filesystem`` transport creates the message file under its final name and
then writes it; a worker polling the folder at that moment may take the file while it is
still empty and die on the JSON decode error. Here a message is written under a name the
readers ignore (``*.msg.part``) and renamed to its final name (``os.replace``: atomic on
one filesystem), so a reader sees a whole message or none. Reading is kombu's (its
``_get`` also tolerates a file another worker took first).
"""

from __future__ import annotations

import contextlib
import os
import uuid
from time import monotonic
from typing import Any

from kombu.exceptions import ChannelError
from kombu.transport import filesystem
from kombu.utils.encoding import str_to_bytes
from kombu.utils.json import dumps


class Channel(filesystem.Channel):
    # kombu's filesystem Channel itself renames AbstractChannel._put's "message" to "payload" (its stub
    # ignores the same override error); kombu passes both positionally, so the signature here is kombu's
    def _put(self, queue: str, payload: dict[str, Any], **kwargs: Any) -> None:  # type: ignore[override]
        name = f"{round(monotonic() * 1000)}_{uuid.uuid4()}.{queue}.msg"
        final = os.path.join(self.data_folder_out, name)
        part = final + ".part"  # filename.partition('.')[2] is "<queue>.msg.part": no reader takes it
        try:
            with open(part, "wb", buffering=0) as f:
                f.write(str_to_bytes(dumps(payload)))
            os.replace(part, final)
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.unlink(part)
            raise ChannelError(f"Cannot add file {final!r} to directory") from exc


class Transport(filesystem.Transport):
    Channel = Channel


#: the value of Celery's ``broker_transport`` for the embedded broker
TRANSPORT = "alcove.jobs.fs_transport:Transport"
