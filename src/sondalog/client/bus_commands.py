"""Typed helpers of the bus master, one per command of hctmps1.md §4."""

from __future__ import annotations

from sondalog.client.bus_errors import NoReply, UnexpectedReply


def _status(text: str) -> bool:
    if text == "<OK>":
        return True
    if text == "<FA>":
        return False
    raise UnexpectedReply(f"expected <OK> or <FA>, got {text!r}")


def _id_list(text: str) -> list[str]:
    return [] if text == "<EMPTY>" else text.split(",")


class BusCommands:
    """The commands of §4 over :meth:`command` (implemented by the bus master)."""

    async def command(
        self, dst: str, command: str, param: str | None = None, *, retries: int | None = None
    ) -> str:
        raise NotImplementedError

    async def hello(self, module: str) -> str:
        return await self.command(module, "HELLO")

    async def getver(self, module: str) -> str:
        return await self.command(module, "GETVER")

    async def connect(self, module: str, password: str) -> bool:
        """Open ``<connect>``; False if the module stays silent (wrong password, lockout)."""
        try:
            return _status(await self.command(module, "CONNECT", password, retries=1))
        except NoReply:
            return False

    async def disconnect(self, module: str) -> None:
        _status(await self.command(module, "DISCONNECT"))

    async def reinit(self, module: str) -> None:
        _status(await self.command(module, "REINIT"))

    async def resee(self, module: str) -> None:
        _status(await self.command(module, "RESEE"))

    async def saveee(self, module: str) -> None:
        _status(await self.command(module, "SAVEEE"))

    async def setmid(self, module: str, new_id: str) -> bool:
        return _status(await self.command(module, "SETMID", new_id))

    async def addsup(self, module: str, supervisor: str) -> bool:
        return _status(await self.command(module, "ADDSUP", supervisor))

    async def delsup(self, module: str, supervisor: str) -> bool:
        return _status(await self.command(module, "DELSUP", supervisor))

    async def listsup(self, module: str) -> list[str]:
        return _id_list(await self.command(module, "LISTSUP"))

    async def addp(self, module: str, symbol: str) -> bool:
        return _status(await self.command(module, "ADDP", symbol))

    async def delp(self, module: str, symbol: str) -> bool:
        return _status(await self.command(module, "DELP", symbol))

    async def listp(self, module: str) -> str | None:
        text = await self.command(module, "LISTP")
        return None if text == "<EMPTY>" else text

    async def newpw(self, module: str, password: str) -> bool:
        return _status(await self.command(module, "NEWPW", password))

    async def pv_text(self, module: str) -> str:
        """``PV`` as the module sends it (``21.44``)."""
        return await self.command(module, "PV")

    async def pv(self, module: str) -> float:
        text = await self.pv_text(module)
        try:
            return float(text)
        except ValueError:
            raise UnexpectedReply(f"RPV.{text} is not a number") from None

    async def csservon(self, module: str, target: str) -> bool:
        return _status(await self.command(module, "CSSERVON", target))

    async def csservoff(self, module: str, target: str) -> bool:
        return _status(await self.command(module, "CSSERVOFF", target))

    async def csservlist(self, module: str) -> list[str]:
        return _id_list(await self.command(module, "CSSERVLIST"))

    async def autoon(self, module: str) -> None:
        _status(await self.command(module, "AUTOON"))

    async def autooff(self, module: str) -> None:
        _status(await self.command(module, "AUTOOFF"))

    async def getmode(self, module: str) -> bool:
        """True if autonomous mode is on (``MDISON``)."""
        text = await self.command(module, "GETMODE")
        if text not in ("MDISON", "MDISOF"):
            raise UnexpectedReply(f"RGETMODE.{text}")
        return text == "MDISON"
