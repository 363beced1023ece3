"""The tag stage's step control of the decoupled texel cache (:mod:`rtl.texcache_decoupled`): which corners a
step checks, whether it misses and is the lookup's last, when it fires, the handshake with the prefetch and set
stages, the registered outcomes and the decisions taken a clock ahead (``docs/texcache.md``). A mixin of
:class:`rtl.texcache_decoupled.DecoupledTexCache`, apart from its stages and memories so that each file has one
job."""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Const, Mux, Signal

from rtl.streams import buffered_room

from .texcache_tags import step_decision
from .unit import named, with_next

__all__ = ["StepControl"]


class StepControl:
    """The step's control (module docstring); the cache provides ``params``, ``skip``, ``_load``."""

    def _advance(self, m, stages, step, st):
        """The tag stage after this clock: it takes the prefetch stage's lookup on ``accept`` (``stages``: the
        prefetch and the tag stage), empties after the lookup's last step, else moves to its next corner (LRU) or
        between its check and its fill (round robin); ``step``: ``(fire, accept, last, step_miss)``; ``st``: the next
        corner and its next value, the fill count and the round-robin fill's registers (``upd``, ``mq``, ``first``)."""
        (pre, t), (fire, accept, last, step_miss) = stages, step
        with m.If(accept):
            self._load(m, t, pre, [pre.c[q].hot for q in range(4)])
            m.d.comb += st.k_next.eq(0)
            m.d.sync += [st.nf.eq(0), st.upd.eq(0)]
        with m.Elif(fire & last):
            m.d.comb += t.valid_next.eq(0)
            m.d.sync += st.upd.eq(0)
        if self.params.replacement == "fifo":
            with m.Elif(fire & st.upd):                          # the fill done: decide again from the next corner
                m.d.comb += st.k_next.eq(st.mq + 1)
                m.d.sync += [st.nf.eq(st.nf + 1), st.upd.eq(0)]
            with m.Elif(fire):                                   # the hits before the first miss: fill it next
                m.d.comb += st.k_next.eq(st.first)
                m.d.sync += [st.mq.eq(st.first), st.upd.eq(1)]
        else:
            with m.Elif(fire):
                m.d.comb += st.k_next.eq(st.k + 1)
                m.d.sync += st.nf.eq(st.nf + step_miss)

    @staticmethod
    def _last(allin, k):
        """LRU: whether a step is its lookup's last: it takes every remaining corner (``allin``), or the last one."""
        return allin | (k == 3)

    def _fires(self, s):
        """Whether the tag stage's step fires in a state ``s`` (this clock's registers or their next values): it
        holds a lookup (``t_valid``) with current outcomes (``hits_ok``), the lookup FIFO has room (``room``) for
        the lookup's ``last`` step, and a miss (``step_miss``) finds a free miss register (``inflight``)."""
        return s.t_valid & s.hits_ok & (s.room | ~s.last) & (~s.step_miss | (s.inflight < self.params.misses))

    def _handshake(self, m, f, input_stage, p_valid, tag_stage, last, step_miss, ahead, platform):
        """Whether the tag stage's step fires (:meth:`_fires`; ``tag_stage``: its valid bit and ``hits_ok``; the
        lookup FIFO's room is a register equal to its ``w_rdy``, :func:`rtl.streams.buffered_room`), the prefetch
        stage's lookup is accepted and the set stage's loaded into the prefetch stage (and the input FIFO read):
        ``(fire, accept, p_load, (room, after))`` (``after``: :func:`rtl.streams.buffered_room`'s). With
        ``ahead`` (LRU) the firing is its register (:meth:`_fire_ahead`), so all four are a logic level or two from
        registers: they are the clock enables of the held stages, the input FIFO and the lookup FIFO, hundreds of
        flip-flops spread over the cache."""
        (s_valid, ififo), (t_valid, hits_ok) = input_stage, tag_stage
        room = buffered_room(m, f.lfifo, self.params.lookup_depth, f.lfifo.w_en, "lfifo")
        fire, accept, p_load = Signal(name="fire"), Signal(), Signal()
        now = SimpleNamespace(t_valid=t_valid, hits_ok=hits_ok, room=room[0], last=last, step_miss=step_miss,
                              inflight=f.inflight)
        if ahead is None:
            m.d.comb += fire.eq(self._fires(now))
        else:
            m.d.comb += fire.eq(ahead.fire)
            if platform == "formal":   # this clock's firing from its registers (invariant firing_decided_ahead)
                m.d.comb += Signal(name="now_fire").eq(self._fires(now))
        m.d.comb += [accept.eq(p_valid & (~t_valid | (fire & last))),
                     p_load.eq(s_valid & (~p_valid | accept)), ififo.r_en.eq(~s_valid | p_load)]
        return fire, accept, p_load, room

    def _fire_ahead(self, m, ahead, nxt):
        """LRU: the registers ``ahead.fire`` and ``ahead.last`` take what the step's firing (:meth:`_fires`) and
        whether it is the lookup's last (``allin``, or the last corner) are in the next clock, from the next values
        of the registers they are functions of (``nxt``: :func:`rtl.unit.with_next`). Equal on every clock to the
        same functions of this clock's registers (formal invariant ``firing_decided_ahead``): the decision goes from
        the registers through the next-state logic into two flip-flops beside it, not through the handshake into the
        clock enables of the whole cache (the Berlin wall engine's slowest routed paths, from the step's decision
        across the die to the input FIFO's read and the tag store's read port: ``docs/texcache.md``). The next
        decision (``allin``, ``step_miss``: the prefetch stage's compares through the step's decision) is the
        deepest of those values, so it selects at the last level among the firings for each of its four values,
        each from the other, shallow, next values; and the lookup FIFO's read (the data stage's decision, across the
        cache) selects after it, between the rooms after a read and after none."""
        last = self._last(nxt.allin, nxt.k)
        fires = {}
        for read in (0, 1):
            for allin in (0, 1):
                for miss in (0, 1):
                    state = SimpleNamespace(**{**vars(nxt), "last": self._last(Const(allin), nxt.k),
                                               "step_miss": Const(miss),
                                               "room": nxt.room.if_read if read else nxt.room.if_not})
                    fires[read, allin, miss] = named(m, self._fires(state), f"fire_if{read}{allin}{miss}")

        def pick(read):
            return Mux(nxt.allin, Mux(nxt.step_miss, fires[read, 1, 1], fires[read, 1, 0]),
                       Mux(nxt.step_miss, fires[read, 0, 1], fires[read, 0, 0]))

        m.d.sync += [ahead.last.eq(last), ahead.fire.eq(Mux(nxt.room.read, pick(1), pick(0)))]

    @staticmethod
    def _outcomes(m, c, pre, hits_ok, accept, tag_write, fresh=None):
        """The tag stage's registered outcomes (each corner's hit and way) and whether they are current
        (``hits_ok``): taken with the lookup from the prefetch stage's compares, stale after a step that writes
        tags (``tag_write``), then taken again from the compares of the held rows (a clock). With ``fresh`` (LRU:
        the step is decided from the outcomes, :meth:`_decide_ahead`) the outcomes so taken are marked ``fresh``
        and current a clock later, when the decision has been taken from them: the held rows' compares (a pending
        row through the overlay) then end at the outcome registers, not at the decision's (the fetch's slowest
        path out of context, at both seeds measured, once the lookup FIFO's room was a register); a clock more
        per step that fills. Returns ``hits_ok``'s next value (:func:`rtl.unit.with_next`)."""
        ok_next = with_next(m, hits_ok)
        fresh_next = None if fresh is None else with_next(m, fresh)
        with m.If(accept):
            m.d.comb += ok_next.eq(~tag_write)
            if fresh is not None:
                m.d.comb += fresh_next.eq(0)
            m.d.sync += [x.eq(y) for q in range(4) for x, y in ((c[q].hit, pre.c[q].hit),
                                                                (c[q].hit_way, pre.c[q].hit_way))]
        with m.Elif(tag_write):
            m.d.comb += ok_next.eq(0)
        if fresh is not None:
            with m.Elif(fresh):
                m.d.comb += [ok_next.eq(1), fresh_next.eq(0)]
        with m.Elif(~hits_ok):
            m.d.comb += ok_next.eq(1) if fresh is None else fresh_next.eq(1)
            m.d.sync += [x.eq(y) for q in range(4) for x, y in ((c[q].hit, c[q].cmp_hit),
                                                                (c[q].hit_way, c[q].cmp_way))]
        return ok_next

    def _live(self, m, c, req, todo, name):
        """Each corner of ``c`` is live when distinct (not a duplicate), ``todo(q)`` and the lookup not skipped."""
        live = [Signal(name=f"{name}{q}") for q in range(4)]
        for q in range(4):
            x = ~c[q].dup & todo(q)
            m.d.comb += live[q].eq(x & ~req.skip if self.skip else x)
        return live

    def _steps_one_phase(self, m, c, live, same, k, platform):
        """LRU: the corners a step checks (``act``), whether it misses, whether it is the lookup's last, and the
        registers that decide it (``ahead``: :func:`rtl.texcache_tags.step_decision` of the held lookup, decided a
        clock ahead by :meth:`_decide_ahead`, so that neither a compare's outcome nor the corners' relations lie
        between the registers and the step's firing, the lookup's acceptance and the enables of every held row). A
        step's hits and its miss update the rows in the clock it fires."""
        ahead = SimpleNamespace(allin=Signal(name="allin"), step_miss=Signal(name="step_miss"),
                                fire=Signal(name="fire_ahead"), last=Signal(name="last_ahead"))
        ahead.allin_next, ahead.step_miss_next = with_next(m, ahead.allin), with_next(m, ahead.step_miss)
        if platform == "formal":
            # the same decision from this clock's registers (``now_allin``, ``now_step_miss``): equal to ``ahead``'s
            # whenever the outcomes are current (formal invariant ``decision_ahead``); nothing else reads it
            step_decision(m, [c[q].hit for q in range(4)], live, same, k, "now_")
            # ``last_ahead`` from this clock's registers (formal invariant ``firing_decided_ahead``)
            m.d.comb += Signal(name="now_last").eq(self._last(ahead.allin, k))
        act = [Signal(name=f"act{q}") for q in range(4)]         # corners checked in this step
        for q in range(4):
            m.d.comb += act[q].eq(live[q] & Mux(ahead.allin, 1, k == q))
        return act, ahead.step_miss, ahead.last, ahead

    def _decide_ahead(self, m, ahead, held, pre, fresh, accept, step_on):
        """The registers of :meth:`_steps_one_phase`'s decision for the clock after this one, from what the
        outcome registers (:meth:`_outcomes`) take in this clock: the prefetch stage's compares with the lookup
        it hands over (corner 0 next), the outcomes themselves in the clock after they were taken again after a
        fill (``fresh``), or, after a step of one corner that writes no tag (``step_on``: it fired and was not the
        last; a hit), the same outcomes with the next corner. After a step that writes tags the outcomes are stale
        and these registers with them; they are decided again a clock after the outcomes are taken again.
        ``held``: the tag stage's corners, request, live corners, equal sets and next corner."""
        c, req, live, same, k = held

        def take(hits, live, same_, kk, name):
            allin, step_miss = step_decision(m, hits, live, same_, kk, name)
            m.d.comb += [ahead.allin_next.eq(allin), ahead.step_miss_next.eq(step_miss)]

        with m.If(accept):
            take([pre.c[q].hit for q in range(4)], self._live(m, pre.c, pre.req, lambda q: 1, "p_live"),
                 pre.same, 0, "p_")
        with m.Elif(fresh):
            take([c[q].hit for q in range(4)], live, same, k, "c_")
        with m.Elif(step_on):
            take([c[q].hit for q in range(4)], self._live(m, c, req, lambda q: q > k, "k_live"),
                 same, k + 1, "k_")

    def _steps_two_phase(self, m, c, live, upd, mq):
        """Round robin: a hit changes no row, so a step is either the remaining corners up to the first that misses
        (all of them when none misses; the lookup's last step then), which decides and writes nothing, or (``upd``)
        the fill of that corner (``mq``), from registers alone: its victim, its row, its burst. The compare of the
        rows with the lines reaches the lookup's acceptance only, never a row. Returns ``(act, step_miss, last,
        first)``, ``first`` the first corner that misses."""
        miss = [Signal(name=f"miss{q}") for q in range(4)]
        for q in range(4):
            m.d.comb += miss[q].eq(live[q] & ~c[q].hit)
        first = Signal(2, name="first_miss")
        for q in reversed(range(4)):
            with m.If(miss[q]):
                m.d.comb += first.eq(q)
        after = Signal()                                         # corners left after the one being filled
        m.d.comb += after.eq(sum(live[q] & (mq < q) for q in range(1, 4)) != 0)
        act = [Signal(name=f"act{q}") for q in range(4)]
        for q in range(4):
            earlier = sum(miss[j] for j in range(q + 1)) != 0
            m.d.comb += act[q].eq(Mux(upd, mq == q, live[q] & ~earlier))
        step_miss, last = Signal(), Signal()
        m.d.comb += [step_miss.eq(upd), last.eq(Mux(upd, ~after, sum(miss) == 0))]
        return act, step_miss, last, first
