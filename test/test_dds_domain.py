"""Each test run holds a DDS domain of its own, so two runs on one machine never cross-talk."""

from __future__ import annotations

import os

import conftest
import pytest


def test_a_domain_held_by_one_run_is_never_given_to_another() -> None:
    assert os.environ['ROS_DOMAIN_ID'] == str(conftest._DOMAIN)
    # two more runs starting from the same process id modulo 100 (as two runs once did)
    first, first_lock = conftest._private_domain()
    second, second_lock = conftest._private_domain()
    try:
        assert first_lock is not None and second_lock is not None
        assert len({first, second, conftest._DOMAIN}) == 3 or (
            conftest._DOMAIN_LOCK is None and first != second)  # a named domain: not locked
        assert all(1 <= d <= 100 for d in (first, second))
    finally:
        for lock in (first_lock, second_lock):
            if lock is not None:
                lock.close()


# -- ./run.sh demo (bench_demo) and every run: a domain free on this machine -------------------
def test_a_domain_whose_port_another_dds_participant_bound_is_not_taken() -> None:
    """The demo took 1 + pid % 100 and could join another program's DDS domain.

    A participant of any program binds UDP ports of its domain (7400 + 250·d + 10 + 2p …):
    such a domain is passed over, as a domain another gyro_calib run holds is.
    """
    import socket

    from gyro_calib.nodes.processes import DOMAINS, domain_ports, hold_free_domain

    for start in range(len(DOMAINS)):  # the first domain whose discovery port we can bind
        busy = DOMAINS[start]
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind(('127.0.0.1', domain_ports(busy)[10]))
        except OSError:
            sock.close()
            continue
        break
    try:
        choice = hold_free_domain(start)
        try:
            assert choice.domain != busy and choice.lock is not None
            assert choice.how == 'free: no other run or DDS participant on this machine uses it'
        finally:
            if choice.lock is not None:
                choice.lock.close()
    finally:
        sock.close()


def test_the_ports_of_a_domain_follow_the_rtps_port_mapping() -> None:
    from gyro_calib.nodes.processes import domain_ports

    assert domain_ports(37) == range(16650, 16900)  # a node in domain 37 bound 16660, 16661


def test_every_domain_busy_falls_back_to_the_process_id_and_says_so() -> None:
    from gyro_calib.nodes.processes import DOMAINS, hold_free_domain

    every_port = set(range(7400, 7400 + 250 * (DOMAINS[-1] + 1)))
    choice = hold_free_domain(41, bound=lambda: every_port)
    assert (choice.domain, choice.lock) == (42, None)
    assert choice.how == 'none free on this machine: taken from the process id, may be shared'


def test_a_domain_named_in_ros_domain_id_is_taken_as_given(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from gyro_calib.nodes.processes import choose_domain

    monkeypatch.setenv('ROS_DOMAIN_ID', '17')
    assert (choose_domain().domain, choose_domain().how) == (17, 'ROS_DOMAIN_ID')
