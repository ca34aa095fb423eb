//! proptest strategies for every message type, shared by the integration tests.
//!
//! Floats are kept finite: NaN != NaN would make equality-based round trips
//! fail for reasons unrelated to encoding. `min_len` lets the struct-shape test
//! ask for non-empty sequences so element types are visible.

#![allow(dead_code)]

use avacraft_msgs::{
    AbilityState, ActionBatch, AreaEffect, EpisodeStatus, Header, Image, ModelCall, RoleAssignment, RoleGroup, SessionInfo, StdString,
    TeamFeatures, TeamObservation, Time, UnitAction, UnitObservation, UnitState,
};
use proptest::collection::vec;
use proptest::prelude::*;

pub fn float() -> impl Strategy<Value = f32> {
    prop_oneof![Just(0.0f32), -1.0e6f32..1.0e6f32, Just(f32::MAX), Just(f32::MIN_POSITIVE)]
}

pub fn text() -> impl Strategy<Value = String> {
    // Any Unicode except NUL, which a CDR string cannot carry.
    "[^\u{0}]{0,12}"
}

pub fn time() -> impl Strategy<Value = Time> {
    (any::<i32>(), 0u32..1_000_000_000).prop_map(|(sec, nanosec)| Time { sec, nanosec })
}

pub fn header() -> impl Strategy<Value = Header> {
    (time(), text()).prop_map(|(stamp, frame_id)| Header { stamp, frame_id })
}

pub fn std_string() -> impl Strategy<Value = StdString> {
    text().prop_map(|data| StdString { data })
}

pub fn image(min_len: usize) -> impl Strategy<Value = Image> {
    (header(), any::<u32>(), any::<u32>(), text(), any::<u8>(), any::<u32>(), vec(any::<u8>(), min_len..64)).prop_map(
        |(header, height, width, encoding, is_bigendian, step, data)| Image { header, height, width, encoding, is_bigendian, step, data },
    )
}

pub fn unit_state(_min_len: usize) -> impl Strategy<Value = UnitState> {
    (
        (any::<u32>(), text(), any::<u8>(), any::<u8>(), any::<bool>(), float(), float(), float(), float()),
        (float(), float(), float(), float(), float(), float(), any::<u8>(), any::<u8>(), any::<u8>()),
        (float(), float(), any::<u32>(), any::<u8>(), any::<u32>(), any::<u32>(), any::<u32>(), any::<u8>()),
    )
        .prop_map(
            |(
                (tag, name, unit_type, team, own, x, y, hp, max_hp),
                (shield, max_shield, energy, max_energy, speed, weapon_cooldown_s, grid_x, grid_y, order),
                (order_x, order_y, order_target, activity, target_tag, flags, buffs, data_set),
            )| UnitState {
                tag,
                name,
                unit_type,
                team,
                own,
                x,
                y,
                hp,
                max_hp,
                shield,
                max_shield,
                energy,
                max_energy,
                speed,
                weapon_cooldown_s,
                grid_x,
                grid_y,
                order,
                order_x,
                order_y,
                order_target,
                activity,
                target_tag,
                flags,
                buffs,
                data_set,
            },
        )
}

pub fn ability_state() -> impl Strategy<Value = AbilityState> {
    (any::<u8>(), any::<bool>(), any::<u8>(), float(), float(), float(), any::<u8>()).prop_map(
        |(ability, available, unavailable, cooldown_s, energy_cost, range, target_kind)| AbilityState {
            ability,
            available,
            unavailable,
            cooldown_s,
            energy_cost,
            range,
            target_kind,
        },
    )
}

pub fn area_effect() -> impl Strategy<Value = AreaEffect> {
    (any::<u8>(), any::<u8>(), float(), float(), float(), float()).prop_map(|(kind, team, x, y, radius, remaining_s)| AreaEffect {
        kind,
        team,
        x,
        y,
        radius,
        remaining_s,
    })
}

pub fn unit_observation(min_len: usize) -> impl Strategy<Value = UnitObservation> {
    (
        (header(), any::<u64>(), any::<u64>(), any::<u32>(), any::<u32>(), any::<u32>(), any::<bool>(), unit_state(min_len)),
        (vec(unit_state(min_len), min_len..3), vec(unit_state(min_len), min_len..3), vec(ability_state(), min_len..3)),
        (vec(area_effect(), min_len..3), vec(any::<u8>(), min_len..16), vec(float(), min_len..16), text()),
    )
        .prop_map(
            |(
                (header, episode, seed, step, game_loop, unit_tag, alive, own),
                (allies, enemies, abilities),
                (effects, avail_actions, features, text),
            )| UnitObservation {
                header,
                episode,
                seed,
                step,
                game_loop,
                unit_tag,
                alive,
                own,
                allies,
                enemies,
                abilities,
                effects,
                avail_actions,
                features,
                text,
            },
        )
}

pub fn team_observation(min_len: usize) -> impl Strategy<Value = TeamObservation> {
    (
        header(),
        any::<u64>(),
        any::<u32>(),
        any::<u32>(),
        any::<u8>(),
        vec(unit_state(min_len), min_len..3),
        vec(area_effect(), min_len..3),
        text(),
    )
        .prop_map(|(header, episode, step, game_loop, team, units, effects, text)| TeamObservation {
            header,
            episode,
            step,
            game_loop,
            team,
            units,
            effects,
            text,
        })
}

pub fn unit_action() -> impl Strategy<Value = UnitAction> {
    (
        any::<u32>(),
        any::<u8>(),
        any::<u32>(),
        float(),
        float(),
        any::<u8>(),
        any::<u8>(),
        any::<u8>(),
        any::<u8>(),
        any::<u8>(),
        any::<u8>(),
        any::<u8>(),
    )
        .prop_map(
            |(unit_tag, kind, target_tag, x, y, grid_x, grid_y, direction, ability, ability_target, look_sector, look_sectors)| {
                UnitAction {
                    unit_tag,
                    kind,
                    target_tag,
                    x,
                    y,
                    grid_x,
                    grid_y,
                    direction,
                    ability,
                    ability_target,
                    look_sector,
                    look_sectors,
                }
            },
        )
}

pub fn action_batch(min_len: usize) -> impl Strategy<Value = ActionBatch> {
    (header(), any::<u64>(), any::<u32>(), text(), vec(unit_action(), min_len..4))
        .prop_map(|(header, episode, step, agent_id, actions)| ActionBatch { header, episode, step, agent_id, actions })
}

pub fn episode_status() -> impl Strategy<Value = EpisodeStatus> {
    (
        (header(), any::<u64>(), any::<u64>(), text(), any::<u32>(), any::<u32>(), any::<u8>()),
        ([float(), float()], any::<[u32; 2]>(), any::<[u32; 2]>(), any::<[u32; 2]>(), any::<u32>(), any::<u64>(), any::<u64>()),
    )
        .prop_map(
            |(
                (header, episode, seed, scenario, step, game_loop, result),
                (reward, refused_actions, missing_actions, foreign_actions, malformed_messages, state_hash, trajectory_hash),
            )| EpisodeStatus {
                header,
                episode,
                seed,
                scenario,
                step,
                game_loop,
                result,
                reward,
                refused_actions,
                missing_actions,
                foreign_actions,
                malformed_messages,
                state_hash,
                trajectory_hash,
            },
        )
}

pub fn session_info(min_len: usize) -> impl Strategy<Value = SessionInfo> {
    (
        (header(), text(), text(), any::<u32>(), any::<u8>(), any::<u8>(), any::<u32>(), any::<bool>()),
        (any::<bool>(), any::<bool>(), any::<[bool; 2]>(), any::<bool>(), any::<u8>(), any::<u32>(), text(), any::<u64>()),
        vec(any::<u64>(), min_len..5),
        (any::<f32>(), any::<bool>(), any::<u8>()),
    )
        .prop_map(
            |(
                (header, scenario_name, scenario_toml, step_mul, reward, opponent, time_limit_loops, ability_actions),
                (full_vision, cooldown_jitter, auto_acquire, abilities, clock, deadline_ms, launch_file, episode),
                seeds,
                (prob_obs_enemy, action_mask, fov_actions),
            )| SessionInfo {
                header,
                scenario_name,
                scenario_toml,
                step_mul,
                reward,
                opponent,
                time_limit_loops,
                ability_actions,
                full_vision,
                cooldown_jitter,
                auto_acquire,
                abilities,
                prob_obs_enemy,
                action_mask,
                fov_actions,
                clock,
                deadline_ms,
                launch_file,
                episode,
                seeds,
            },
        )
}

pub fn role_group(min_len: usize) -> impl Strategy<Value = RoleGroup> {
    (any::<u8>(), text(), vec(any::<u32>(), min_len..8)).prop_map(|(role, agent_id, unit_tags)| RoleGroup { role, agent_id, unit_tags })
}

pub fn role_assignment(min_len: usize) -> impl Strategy<Value = RoleAssignment> {
    (header(), any::<u64>(), any::<u32>(), any::<u8>(), vec(role_group(min_len), min_len..3), text(), vec(any::<u32>(), min_len..4))
        .prop_map(|(header, episode, step, team, groups, plan, priority_tags)| RoleAssignment {
            header,
            episode,
            step,
            team,
            groups,
            plan,
            priority_tags,
        })
}

pub fn team_features(min_len: usize) -> impl Strategy<Value = TeamFeatures> {
    (header(), any::<u8>(), text(), vec(-1e6..1e6f32, min_len..32)).prop_map(|(header, team, encoder, data)| TeamFeatures {
        header,
        team,
        encoder,
        data,
    })
}

pub fn model_call(min_len: usize) -> impl Strategy<Value = ModelCall> {
    (
        (header(), any::<u64>(), any::<u32>(), any::<u8>(), any::<u32>(), any::<u8>(), any::<u32>(), any::<u32>()),
        (text(), text(), text(), text(), text(), text()),
        (any::<u32>(), any::<u32>(), -1e9..1e9f64, -1e9..1e9f64, any::<u32>(), vec(any::<u8>(), min_len..64)),
    )
        .prop_map(
            |(
                (header, episode, step, team, decision, stage, attempt, retry),
                (model, prompts_version, request_hash, request_json, response, error),
                (prompt_tokens, completion_tokens, latency_ms, cost_usd, images, first_image_png),
            )| ModelCall {
                header,
                episode,
                step,
                team,
                decision,
                stage,
                attempt,
                retry,
                model,
                prompts_version,
                request_hash,
                request_json,
                response,
                error,
                prompt_tokens,
                completion_tokens,
                latency_ms,
                cost_usd,
                images,
                first_image_png,
            },
        )
}
