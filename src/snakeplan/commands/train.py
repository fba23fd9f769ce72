"""``snakeplan train``: train a learned agent (``sscc``: the SSCC swinging-search agent; ``rl``: a learned tip
planner). ``python -m snakeplan.rl.train``, the command shipped policies record, is ``train rl`` with the trainer
options as options of its own (:func:`trainer_parser`)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_OK, Parser, UsageError, seed, seed_list
from snakeplan.commands.options import backend, backend_args
from snakeplan.extras import require_training
from snakeplan.files import check_output

#: ``python -m snakeplan.rl.train``'s description.
TRAINER_DESCRIPTION = ("Train sac-her / sac-per / sac on a scene family: 'snakeplan train rl' under the name "
                       "shipped policies record; the trainer options set the training configuration.")


def add_parser(sub) -> None:
    p = sub.add_parser("train", help="train a learned agent (sscc, rl)",
                       description="Train a learned agent; writes plain .npz weights.")
    tsub = p.add_subparsers(dest="train", required=True, parser_class=Parser, metavar="AGENT")
    t = tsub.add_parser("sscc", help="the SSCC swinging-search agent (DDPG)")
    t.add_argument("--robot", default="sscc-24", help="sscc-16 or sscc-24 (default sscc-24)")
    t.add_argument("--out", required=True, help="output .npz weight file; its resumable state goes to the folder "
                                                "OUT.state beside it")
    t.add_argument("--steps", type=int, default=12000, help="environment steps (default 12000)")
    t.add_argument("--seed", type=seed, default=0, help="training seed (default 0)")
    t.add_argument("--checkpoint-every", type=int, default=0,
                   help="environment steps between checkpoints (default: a tenth of --steps, 1000-10000)")
    t.add_argument("--fresh", action="store_true", help="delete the checkpoint in OUT.state and start over")
    t.set_defaults(func=cmd_train)
    t = tsub.add_parser("rl", help="a learned tip planner (sac-her, sac-per, sac)",
                        description="Train sac-her / sac-per / sac on a scene family with targets; resumes from the "
                                    "checkpoint in --out (Ctrl-C saves one; --checkpoint-every N, default a tenth "
                                    "of --steps within 1000-10000). Any further option sets the training configuration "
                                    "(--robot my_arm.json for your own arm, --arm-conditioned true for one policy "
                                    "over a distribution of arms, --paper, --turn-radius-mm 215, --capture-steps 4, "
                                    "--eval-episodes 50, ...; the list: 'python -m snakeplan.rl.train --help').")
    _rl_arguments(t)
    t.set_defaults(func=cmd_train_rl, takes_options=True)


def _rl_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``train rl`` (and of ``python -m snakeplan.rl.train``) but the trainer options."""
    p.add_argument("scene", help="a scene family with targets (fuel-tank, oil-tank, pipe, or one you registered)")
    p.add_argument("algorithm", choices=("sac-her", "sac-per", "sac"))
    p.add_argument("--steps", type=int, required=True, help="environment steps")
    p.add_argument("--seed", type=seed, default=0, help="training seed (default 0)")
    p.add_argument("--out", required=True, help="output folder (policy.npz, curve.png, checkpoints)")
    p.add_argument("--fresh", action="store_true", help="delete the checkpoint in --out and start over")
    p.add_argument("--seeds", help="a training sweep: one resumable training per seed (e.g. 0-9) in --out/seed<N>, "
                                   "on --workers processes or Ray, and a summary of the learning curves")
    backend_args(p)


def trainer_parser() -> Parser:
    """The parser of ``python -m snakeplan.rl.train``: ``train rl``'s, with the trainer options (the training
    configuration, :func:`snakeplan.rl.train.add_config_arguments`) parsed and listed in its --help."""
    from snakeplan.rl.train import add_config_arguments

    p = Parser(prog="python -m snakeplan.rl.train", description=TRAINER_DESCRIPTION)
    _rl_arguments(p)
    add_config_arguments(p.add_argument_group("trainer options"))
    p.set_defaults(func=cmd_trainer)
    return p


def cmd_train(args: argparse.Namespace) -> int:
    """Interrupted (SIGINT, SIGTERM), it saves a checkpoint; main() says so in one line, exit 130."""
    require_training("train sscc")
    from snakeplan.rl.sscc import check_agent_robot, train_agent

    check_output(args.out, "--out")
    if args.steps < 1:
        raise UsageError(f"--steps: expected a positive integer, got {args.steps}")
    if args.checkpoint_every < 0:
        raise UsageError(f"--checkpoint-every: expected a non-negative integer, got {args.checkpoint_every}")
    check_agent_robot(args.robot, "--robot")
    result = train_agent(args.robot, args.out, steps=args.steps, seed=args.seed, resume=not args.fresh,
                         checkpoint_every=args.checkpoint_every)
    sys.stdout.write(f"{result}\nwrote {args.out}\n")
    return EXIT_OK


def cmd_train_rl(args: argparse.Namespace) -> int:
    """``train rl``: the trainer options are the arguments the parser left (``args.extra``). Interrupted (SIGINT,
    SIGTERM), it saves a checkpoint; main() says so in one line, exit 130."""
    require_training("train rl")
    from snakeplan.rl.train import parse_config

    _check_steps(args)
    return _train_rl(args, parse_config(args.extra))


def cmd_trainer(args: argparse.Namespace) -> int:
    """``python -m snakeplan.rl.train``: ``train rl`` with the trainer options parsed among the others."""
    require_training("train rl")
    from snakeplan.rl.train import config_from

    _check_steps(args)
    return _train_rl(args, config_from(args))


def _check_steps(args: argparse.Namespace) -> None:
    if args.steps < 1:
        raise UsageError(f"--steps: expected a positive integer, got {args.steps}")


def _train_rl(args: argparse.Namespace, config) -> int:
    """Train one seed, or sweep --seeds."""
    from snakeplan.rl.train import train

    if args.seeds is not None:
        from snakeplan.rl.sweep import markdown, train_seeds

        if args.fresh:
            raise UsageError("--fresh: not with --seeds (delete the seed folders in --out to start over)")
        summary = train_seeds(args.scene, args.algorithm, args.steps, seed_list(args.seeds, "--seeds"), args.out,
                              config, backend(args))
        sys.stdout.write(markdown(summary) + f"\nwrote {args.out}/sweep.md, sweep.json, curves.png and one folder "
                         f"per seed\n")
        return EXIT_OK
    result = train(args.scene, args.algorithm, args.steps, args.seed, args.out, config, resume=not args.fresh)
    sys.stdout.write(f"wrote {result.policy}\n")
    return EXIT_OK
