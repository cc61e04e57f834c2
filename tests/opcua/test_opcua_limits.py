"""The writable OPC UA server's limits: a slave input's value outside its four bits is
Bad_OutOfRange (it was stored cut to four bits), Start with an argument
BadTooManyArguments (it was BadUnexpectedError), and wrong passwords are slowed per
client."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from asyncua import Client, ua
from test_opcua import NAMESPACE, asictl, node, served
from test_opcua import state as state

from asictl.opcua import server as opcua_server
from asictl.opcua.server import LOGIN_FREE, LOGIN_WAIT_S, _Login


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_wrong_passwords_make_that_client_wait_and_no_other():
    clock = Clock()
    login = _Login("hmi", "secret", clock)
    for _ in range(LOGIN_FREE):
        assert login.check("10.0.0.9", "hmi", "guess") is None
    # now refused, even with the right password, until the wait is over
    assert login.check("10.0.0.9", "hmi", "secret") is None
    assert login.check("10.0.0.7", "hmi", "secret") is not None  # another client
    clock.now += LOGIN_WAIT_S * 2 + 0.01
    assert login.check("10.0.0.9", "hmi", "secret") is not None
    # the right login forgot the failures
    assert login.check("10.0.0.9", "hmi", "guess") is None
    assert login.check("10.0.0.9", "hmi", "secret") is not None


def test_the_wait_doubles_up_to_its_limit_and_attempts_meanwhile_are_not_counted():
    clock = Clock()
    login = _Login("hmi", "secret", clock)
    waits = []
    for _ in range(LOGIN_FREE + 12):
        assert login.check("c", "hmi", "x") is None
        failures, until = login._failures["c"]
        waits.append(until - clock.now)
        if until > clock.now:
            for _ in range(100):  # refused unseen: neither counted nor lengthening the wait
                assert login.check("c", "hmi", "secret") is None
            assert login._failures["c"] == (failures, until)
        clock.now = until
    assert waits[:LOGIN_FREE - 1] == [0.0] * (LOGIN_FREE - 1)
    assert waits[LOGIN_FREE - 1:LOGIN_FREE + 2] == [LOGIN_WAIT_S, 2 * LOGIN_WAIT_S,
                                                   4 * LOGIN_WAIT_S]
    assert max(waits) == opcua_server.LOGIN_WAIT_MAX_S


def test_the_clients_remembered_are_bounded(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(opcua_server, "LOGIN_CLIENTS", 10)
    login = _Login("hmi", "secret", Clock())
    for client in range(50):
        login.check(f"10.0.0.{client}", "hmi", "x")
    assert len(login._failures) == 10


def test_out_of_range_writes_bad_method_arguments_and_slowed_logins(state: Path):
    async def session(url: str) -> None:
        client = Client(url)
        client.set_user("hmi")
        client.set_password("secret")
        async with client:
            ns = await client.get_namespace_index(NAMESPACE)
            inputs = node(client, ns, "Slave.1.Inputs")
            await inputs.write_value(ua.Variant(0b0101, ua.VariantType.Byte))
            with pytest.raises(ua.UaStatusCodeError) as refused:
                await inputs.write_value(ua.Variant(200, ua.VariantType.Byte))
            assert refused.value.code == ua.StatusCodes.BadOutOfRange
            master = node(client, ns, "Master")
            for method in ("Master.Start", "Master.Stop"):
                with pytest.raises(ua.UaStatusCodeError) as refused:
                    await master.call_method(ua.NodeId(method, ns), ua.Variant(1))
                assert refused.value.code == ua.StatusCodes.BadTooManyArguments
        for _ in range(LOGIN_FREE + 1):
            wrong = Client(url)
            wrong.set_user("hmi")
            wrong.set_password("guess")
            with pytest.raises(ua.UaStatusCodeError):
                async with wrong:
                    pass
        right = Client(url)  # too soon after the failures: refused as well
        right.set_user("hmi")
        right.set_password("secret")
        with pytest.raises(ua.UaStatusCodeError) as refused:
            async with right:
                pass
        assert refused.value.code == ua.StatusCodes.BadUserAccessDenied
        await asyncio.sleep(LOGIN_WAIT_S * 2 + 0.2)
        right = Client(url)
        right.set_user("hmi")
        right.set_password("secret")
        async with right:
            pass

    env = {"ASICTL_OPCUA_PASSWORD": "secret"}
    with served(state, "gateway", "serve", "--tcp", "127.0.0.1:0", "--opcua-writable",
                "--opcua-user", "hmi", env=env) as url:
        asyncio.run(session(url))
        status = json.loads(asictl(state, "status", "--json").stdout)
        assert status["slaves"]["1"]["inputs"] == 0b0101  # 200 stored nothing
